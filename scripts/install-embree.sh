#!/usr/bin/env bash
# Installs Debian's Embree 3 development package (libembree-dev), which the `embree` Cargo
# feature links against (the `embree` crate links `embree3`). Idempotent: does nothing when the
# package is already installed. Needs root (CI runs as root) or sudo.
set -euo pipefail

if dpkg-query -W -f='${Status}' libembree-dev 2>/dev/null | grep -q 'install ok installed'; then
  echo "libembree-dev is already installed: $(dpkg-query -W -f='${Version}' libembree-dev)"
  exit 0
fi

as_root=()
if [ "$(id -u)" -ne 0 ]; then
  as_root=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive
"${as_root[@]}" apt-get update
"${as_root[@]}" apt-get install -y --no-install-recommends libembree-dev
echo "installed libembree-dev $(dpkg-query -W -f='${Version}' libembree-dev)"
