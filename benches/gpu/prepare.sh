#!/usr/bin/env bash
# Run HERE (the dev machine), before a session that has the H200 calls the device tool.
# The device machine has no Rust toolchain and no Vulkan loader: build the release binaries
# here and fetch the loader packages as .debs (the procedure of .library/device/README.md).
# SimGrid (opened at run time by `simulate`) travels as its library and dependencies, packed.
# All land in ignored folders that the device calls carry: `.gpubin` and `.gl` (the GPU call),
# `.gpusim` (the validation call).
set -euo pipefail
cd "$(dirname "$0")/../.."
# .gitignore ignores these folders, which is what lets the device calls carry them.
cargo build --release --features gpu,simgrid --bin raysched --example gpu_dispatch

# Packed with xz: the device call carries the tracked tree (about 50 MB) and these within 64 MiB.
rm -rf .gpubin .gpusim && mkdir -p .gpubin .gpusim
for b in target/release/raysched target/release/examples/gpu_dispatch; do
  strip -o "/tmp/$(basename $b)" "$b"
  xz -9e -T2 -c "/tmp/$(basename $b)" >".gpubin/$(basename $b).xz"
done
git log -1 --format='binaries of commit %H %s' >.gpubin/commit.txt
git status --short | sed 's/^/  uncommitted: /' >>.gpubin/commit.txt
cp .gpubin/commit.txt .gpubin/raysched.xz .gpusim/
# libsimgrid and what it links, but not the C and C++ runtimes the device machine has itself.
sg=/usr/lib/x86_64-linux-gnu/libsimgrid.so.3.32
rm -rf /tmp/sglib && mkdir -p /tmp/sglib
cp -L "$sg" /tmp/sglib/
ldd "$sg" | awk '$3 ~ /^\// {print $3}' | grep -v -E 'libc\.so|libm\.so|ld-linux|libgcc_s|libstdc\+\+' \
  | while read -r f; do cp -L "$f" /tmp/sglib/; done
strip --strip-unneeded /tmp/sglib/*
ln -s libsimgrid.so.3.32 /tmp/sglib/libsimgrid.so
tar -C /tmp -cf - sglib | xz -9e -T2 >.gpusim/sglib.tar.xz
mkdir -p .gl /tmp/amd64/partial
o='-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64'
# shellcheck disable=SC2086
apt-get $o update -q
# shellcheck disable=SC2086
(cd .gl && apt-get $o download libvulkan1 libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2)
du -sh .gpubin .gpusim .gl
echo "now call the device tool twice (benches/gpu/device.sh says how):"
echo "  carry [\".gl\", \".gpubin\"]: bash benches/gpu/device.sh gpu"
echo "  carry [\".gpusim\"]: bash benches/gpu/device.sh validation"
