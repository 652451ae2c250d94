#!/usr/bin/env bash
# Run HERE (the dev machine), before a session that has the H200 calls the device tool.
# The device machine has no Rust toolchain and no Vulkan loader: build the release binaries
# here and fetch the loader packages as .debs (the procedure of .library/device/README.md).
# Both land in ignored folders that the device call carries: `.gpubin` and `.gl`.
set -euo pipefail
cd "$(dirname "$0")/../.."
# .gitignore ignores both folders, which is what lets the device call carry them.
cargo build --release --features gpu --bin raysched --example gpu_dispatch
mkdir -p .gpubin
cp target/release/raysched target/release/examples/gpu_dispatch .gpubin/
strip .gpubin/raysched .gpubin/gpu_dispatch
mkdir -p .gl /tmp/amd64/partial
o='-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64'
# shellcheck disable=SC2086
apt-get $o update -q
# shellcheck disable=SC2086
(cd .gl && apt-get $o download libvulkan1 libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2)
du -sh .gpubin .gl
echo "now call the device tool with carry [\".gl\", \".gpubin\"] and command:"
echo "  bash benches/gpu/device.sh"
