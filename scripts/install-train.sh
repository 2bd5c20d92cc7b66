#!/usr/bin/env bash
# Install simx with the training extra into .venv (or $SIMX_VENV), with PyTorch's CPU build:
#   scripts/install-train.sh            # .[train]: gymnasium, stable-baselines3, PyTorch (CPU), matplotlib
#   scripts/install-train.sh train,ray  # and Ray RLlib (any extras, comma-separated: test,train,ray)
# A plain `pip install -e '.[train]'` takes PyPI's torch, the CUDA build (about 5 GB more); for a
# GPU, install that one instead. SIMX_TORCH (default torch==2.13.0+cpu) and SIMX_TORCH_INDEX
# (default PyTorch's CPU index) change what is installed and from where (scripts/_env.sh).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/_env.sh"
ensure_venv -e "$ROOT[${1:-train}]" "$TORCH_CPU"
echo "simx: done; run the training examples with $VENV/bin/python (docs/TRAINING.md)."
