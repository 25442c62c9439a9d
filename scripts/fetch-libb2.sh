#!/usr/bin/env bash
# Fetches the BLAKE2 reference code (Debian's libb2 source package, CC0) for the board core's
# Cortex-M tests: firmware/ cross-compiles src/blake2b-ref.c as the target's MAC (docs/porting.md).
# Debian ships libb2 for the build machine only, so the source package is fetched with apt (a
# deb-src entry is added for bookworm if there is none) and checked against its known SHA-256.
# Usage: fetch-libb2.sh [DEST]   (default: .deps/libb2 beside this script's repository)
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
dest="${1:-$root/.deps/libb2}"
version="0.98.1"
sha256="10053dbc2fa342516b780a6bbf6e7b2a2360b8d49c5ac426936bf3df82526732"  # libb2_0.98.1.orig.tar.gz (bookworm)

if [ -f "$dest/src/blake2b-ref.c" ]; then
  echo "fetch-libb2: $dest present"
  exit 0
fi
SUDO=""
if [ "$(id -u)" -ne 0 ] && command -v sudo >/dev/null 2>&1; then SUDO="sudo"; fi
if ! grep -rqs "deb-src" /etc/apt/sources.list /etc/apt/sources.list.d/; then
  echo "fetch-libb2: adding a deb-src entry for bookworm (/etc/apt/sources.list.d/peha-deb-src.sources)"
  printf 'Types: deb-src\nURIs: http://deb.debian.org/debian\nSuites: bookworm\nComponents: main\nSigned-By: /usr/share/keyrings/debian-archive-keyring.gpg\n' |
    $SUDO tee /etc/apt/sources.list.d/peha-deb-src.sources >/dev/null
  $SUDO apt-get update -qq
fi
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
(cd "$work" && apt-get source --download-only "libb2=$version-1.1" >/dev/null 2>&1 || apt-get source --download-only libb2 >/dev/null)
tarball="$work/libb2_$version.orig.tar.gz"
if [ ! -f "$tarball" ]; then
  echo "fetch-libb2: apt-get source libb2 gave no libb2_$version.orig.tar.gz (found: $(ls "$work"))" >&2
  exit 1
fi
found="$(sha256sum "$tarball" | cut -d' ' -f1)"
if [ "$found" != "$sha256" ]; then
  echo "fetch-libb2: $tarball: expected SHA-256 $sha256, found $found" >&2
  exit 1
fi
mkdir -p "$dest"
tar -xzf "$tarball" -C "$dest" --strip-components=1 "libb2-$version/src" "libb2-$version/COPYING"
echo "fetch-libb2: libb2 $version source in $dest"
