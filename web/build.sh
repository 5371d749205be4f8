#!/usr/bin/env bash
# Builds the web page from a fresh clone: crates/shadowlab-web for wasm32, then wasm-bindgen
# (wasm-bindgen-cli at the version of the wasm-bindgen crate in Cargo.lock, installed if missing).
# The result is web/ itself (index.html, main.js, pkg/), or a copy in DIR with `--out DIR`: any
# static file server can serve it, e.g. `python3 -m http.server -d web 8080`, then open
# http://localhost:8080/ in a browser with WebGPU.
set -euo pipefail
cd "$(dirname "$0")/.."
# --dev: the dev profile (what CI's wasm build of the engine already compiled; a larger, slower
# page, for the browser test); --out DIR: also copy the page there.
out="" profile="release"
while [ $# -gt 0 ]; do
    case "$1" in
        --out) out="${2:?--out needs a directory}"; shift 2 ;;
        --dev) profile="dev"; shift ;;
        *) echo "usage: web/build.sh [--dev] [--out DIR]" >&2; exit 2 ;;
    esac
done

version=$(grep -A1 '^name = "wasm-bindgen"$' Cargo.lock | sed -n 's/^version = "\(.*\)"$/\1/p')
rustup target add wasm32-unknown-unknown >/dev/null 2>&1 || true
if ! wasm-bindgen --version 2>/dev/null | grep -qx "wasm-bindgen $version"; then
    echo "== cargo install wasm-bindgen-cli $version (once)"
    # With --dev a debug build of the tool: it compiles in about half the time (CI) and still
    # binds the page in seconds.
    debug=""
    if [ "$profile" = dev ]; then debug="--debug"; fi
    # (Without the caller's RUSTFLAGS: CI's -D warnings is for this workspace, not for the tool.
    # --force: cargo's record of an install may outlive its binary.)
    env -u RUSTFLAGS cargo install --force wasm-bindgen-cli --version "$version" $debug
fi
echo "== cargo build --profile $profile --target wasm32-unknown-unknown -p shadowlab-web"
cargo build --profile "$profile" --target wasm32-unknown-unknown -p shadowlab-web
dir=$([ "$profile" = dev ] && echo debug || echo release)
wasm="${CARGO_TARGET_DIR:-target}/wasm32-unknown-unknown/$dir/shadowlab_web.wasm"
rm -rf web/pkg
wasm-bindgen --target web --no-typescript --out-dir web/pkg "$wasm"
echo "web/pkg/shadowlab_web_bg.wasm: $(wc -c < web/pkg/shadowlab_web_bg.wasm) bytes"
if [ -n "$out" ]; then
    mkdir -p "$out"
    cp web/index.html web/main.js "$out"/
    rm -rf "$out/pkg" && cp -r web/pkg "$out/pkg"
    echo "→ $out"
fi
