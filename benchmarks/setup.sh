#!/usr/bin/env bash
# Set up the benchmark peers: Mitsuba 3 from PyPI and a shared libLLVM for its llvm_* variants.
#
# Dr.Jit (Mitsuba's JIT) loads libLLVM at run time. Debian's libllvm15 is found but Dr.Jit 1.5
# emits `llvm.maximum` (fmaximum), which LLVM 15's x86 back end cannot select ("LLVM ERROR:
# Cannot select: fmaximum"), so we install LLVM 19 (Debian bookworm's libllvm19) and point
# DRJIT_LIBLLVM_PATH at it; bench_brdf.py sets that default too.
set -euo pipefail

if ! ls /usr/lib/x86_64-linux-gnu/libLLVM.so.19* >/dev/null 2>&1; then
    SUDO=""
    if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
    $SUDO apt-get update
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y libllvm19
fi
python -m pip install "mitsuba>=3.6" jax numba
python -m pip install pyvista tqdm  # the bilateral normal-integration peer of bench_normal_integration.py

export DRJIT_LIBLLVM_PATH="${DRJIT_LIBLLVM_PATH:-$(ls /usr/lib/x86_64-linux-gnu/libLLVM.so.19* | head -1)}"
python - <<'PY'
import mitsuba as mi
mi.set_variant("llvm_ad_rgb")
print("Mitsuba", mi.__version__, "llvm_ad_rgb ready")
PY
echo "export DRJIT_LIBLLVM_PATH=$DRJIT_LIBLLVM_PATH"
