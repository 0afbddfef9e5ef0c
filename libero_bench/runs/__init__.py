"""Run folders: their files, reading a finished run, the state files, migrating earlier formats."""
