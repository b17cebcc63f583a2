#!/usr/bin/env bash
# Builds the C API and installs it under PREFIX:
#   PREFIX/include/packtrace.h
#   PREFIX/lib/libpacktrace_c.a, libpacktrace_c.so
#   PREFIX/lib/pkgconfig/packtrace.pc             (pkg-config packtrace)
#   PREFIX/lib/cmake/packtrace/packtrace-config*.cmake   (find_package)
# Usage: capi/install.sh PREFIX [--debug]   (release build by default)
set -euo pipefail
[[ $# -ge 1 ]] || { echo "usage: $0 PREFIX [--debug]" >&2; exit 2; }
root="$(cd "$(dirname "$0")/.." && pwd)"
mkdir -p "$1"
prefix="$(cd "$1" && pwd)"
profile=release
[[ "${2:-}" == "--debug" ]] && profile=debug
if [[ $profile == release ]]; then
  cargo build --release -p packtrace-c --manifest-path "$root/Cargo.toml"
else
  cargo build -p packtrace-c --manifest-path "$root/Cargo.toml"
fi
target="$(cd "$root" && cargo metadata --format-version 1 --no-deps \
  | sed -n 's/.*"target_directory":"\([^"]*\)".*/\1/p')/$profile"
version="$(sed -n 's/^version = "\(.*\)"/\1/p' "$root/capi/Cargo.toml" | head -1)"
install -d "$prefix/include" "$prefix/lib/pkgconfig" "$prefix/lib/cmake/packtrace"
install -m 644 "$root/capi/include/packtrace.h" "$prefix/include/"
install -m 644 "$target/libpacktrace_c.a" "$prefix/lib/"
install -m 755 "$target/libpacktrace_c.so" "$prefix/lib/"
sed "s|@PREFIX@|$prefix|; s|@VERSION@|$version|" "$root/capi/packtrace.pc.in" \
  > "$prefix/lib/pkgconfig/packtrace.pc"
install -m 644 "$root/capi/cmake/packtrace-config.cmake" "$prefix/lib/cmake/packtrace/"
sed "s|@VERSION@|$version|" "$root/capi/cmake/packtrace-config-version.cmake.in" \
  > "$prefix/lib/cmake/packtrace/packtrace-config-version.cmake"
echo "installed packtrace $version ($profile) under $prefix"
