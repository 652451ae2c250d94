#!/usr/bin/env bash
# Installs what benches/peers/mitsuba.py needs on Debian 12: the `mitsuba` wheel from PyPI
# (3.9.x; it brings drjit) and Debian's libllvm19 for the llvm_* variants (LLVM 15 crashed on
# the first render, LLVM 14 is refused by Dr.Jit). Not run by CI.
set -euo pipefail
if command -v apt-get >/dev/null; then
    sudo_=""; [ "$(id -u)" = 0 ] || sudo_="sudo"
    DEBIAN_FRONTEND=noninteractive $sudo_ apt-get install -y libllvm19 util-linux
fi
python3 -m pip install 'mitsuba>=3.9,<3.10'
python3 -c 'import mitsuba; print("mitsuba", mitsuba.__version__)'
echo "llvm variants: DRJIT_LIBLLVM_PATH defaults to /usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 in mitsuba.py"
