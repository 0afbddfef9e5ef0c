"""Training data: a libero-data dataset read for training, its windows and batches, mixed datasets, language embeddings."""
