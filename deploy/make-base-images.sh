#!/usr/bin/env bash
# Makes the two base images the Dockerfile names, for a machine that can reach Debian's
# package mirror but no image registry: debootstrap a minimal bookworm root filesystem and
# `podman import` it as docker.io/library/debian:bookworm and ...:bookworm-slim (the slim one
# also drops docs, man pages and locales, and keeps dpkg from installing them, as Debian's
# official slim image does). Where a registry is reachable, skip this and pull the real ones.
#
#   deploy/make-base-images.sh [WORK_DIR]     (root; needs debootstrap and podman)
set -euo pipefail
work=${1:-/var/tmp/strata-base}
mirror=${DEBIAN_MIRROR:-http://deb.debian.org/debian}
security=${DEBIAN_SECURITY_MIRROR:-http://deb.debian.org/debian-security}
rootfs=$work/rootfs

mkdir -p "$work"
if [ ! -x "$rootfs/usr/bin/apt-get" ]; then
  rm -rf "$rootfs"
  debootstrap --variant=minbase bookworm "$rootfs" "$mirror"
fi

# The sources an official image has: the release, its updates and security.
rm -f "$rootfs/etc/apt/sources.list"
cat > "$rootfs/etc/apt/sources.list.d/debian.sources" <<SOURCES
Types: deb
URIs: $mirror
Suites: bookworm bookworm-updates
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg

Types: deb
URIs: $security
Suites: bookworm-security
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
SOURCES
rm -rf "$rootfs"/var/cache/apt/archives/*.deb "$rootfs"/var/lib/apt/lists/* "$rootfs"/tmp/*
: > "$rootfs/etc/resolv.conf"   # the container runtime provides one
: > "$rootfs/etc/hostname"

tar -C "$rootfs" --numeric-owner -c . |
  podman import --change 'CMD ["bash"]' - docker.io/library/debian:bookworm

slim=$work/rootfs-slim
rm -rf "$slim"
cp -a "$rootfs" "$slim"
cat > "$slim/etc/dpkg/dpkg.cfg.d/slim" <<'DPKG'
path-exclude /usr/share/doc/*
path-include /usr/share/doc/*/copyright
path-exclude /usr/share/man/*
path-exclude /usr/share/info/*
path-exclude /usr/share/locale/*
path-include /usr/share/locale/locale.alias
DPKG
find "$slim/usr/share/doc" -mindepth 1 ! -name copyright ! -type d -delete
find "$slim/usr/share/doc" -mindepth 1 -type d -empty -delete
rm -rf "$slim"/usr/share/man/* "$slim"/usr/share/info/*
find "$slim/usr/share/locale" -mindepth 1 -maxdepth 1 ! -name locale.alias -exec rm -rf {} +
tar -C "$slim" --numeric-owner -c . |
  podman import --change 'CMD ["bash"]' - docker.io/library/debian:bookworm-slim
rm -rf "$slim"

podman images --filter reference=docker.io/library/debian
