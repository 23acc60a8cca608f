#!/usr/bin/env bash
# `make install` and `make uninstall` of plsr (README, "From C and C++").
#
#   scripts/install.sh install     installs what cargo built into TARGET
#   scripts/install.sh uninstall   removes what the install put there
#
# Settings come from the environment (the Makefile passes them): PREFIX,
# LIBDIR, BINDIR, INCLUDEDIR (absolute paths on the system the files are for),
# DESTDIR (a staging folder in front of all of them, usually empty), VERSION
# (the crate's, X.Y.Z), ABI_SINCE (the oldest version whose C ABI this one
# keeps; the CMake version file accepts requests from it on) and TARGET (the
# cargo folder holding libplsr.so, libplsr.a and plsr; install only).
#
# What is installed:
#   LIBDIR/libplsr.so.X.Y.Z             the library, stripped
#   LIBDIR/libplsr.so.X -> …X.Y.Z       its soname (what hosts record)
#   LIBDIR/libplsr.so -> libplsr.so.X   for the linker (-lplsr)
#   LIBDIR/.debug/libplsr.so.X.Y.Z.debug  its debug info (found by gdb
#                                       through the library's .gnu_debuglink)
#   LIBDIR/libplsr.a                    the static library (without debug info)
#   LIBDIR/pkgconfig/plsr.pc
#   LIBDIR/cmake/plsr/plsrConfig.cmake, plsrConfigVersion.cmake
#   LIBDIR/plsr/install-manifest.txt    every file and every folder this
#                                       install made, for `make uninstall`
#   INCLUDEDIR/plsr.h, plsr.hpp
#   BINDIR/plsr                         the program, stripped
#   BINDIR/.debug/plsr.debug            its debug info
set -euo pipefail

mode=${1:-}
die() {
  echo "plsr $mode: $*" >&2
  exit 1
}
[ "$mode" = install ] || [ "$mode" = uninstall ] || die "usage: scripts/install.sh install|uninstall"
for v in PREFIX LIBDIR BINDIR INCLUDEDIR VERSION; do
  [ -n "${!v:-}" ] || die "$v is not set"
done
for v in PREFIX LIBDIR BINDIR INCLUDEDIR; do
  # Without trailing slashes (but "/" itself).
  while [ "${!v}" != / ] && [ "${!v%/}" != "${!v}" ]; do
    printf -v "$v" '%s' "${!v%/}"
  done
  case "${!v}" in
    /*) ;;
    *) die "$v must be an absolute path (it is the path on the installed system), got '${!v}'" ;;
  esac
done
D=${DESTDIR:-}
manifest=$LIBDIR/plsr/install-manifest.txt

# Refreshes the dynamic linker's cache when installing for this machine, as
# root, into a folder the linker searches; a private prefix needs an rpath
# or LD_LIBRARY_PATH instead (README).
refresh_ldconfig() {
  [ -z "$D" ] && [ "$(id -u)" -eq 0 ] && command -v ldconfig > /dev/null || return 0
  local dirs
  dirs=$(cat /etc/ld.so.conf /etc/ld.so.conf.d/*.conf 2> /dev/null | sed 's/#.*//') || true
  case "$LIBDIR" in
    /lib | /usr/lib | /lib64 | /usr/lib64 | /lib/*-linux-gnu* | /usr/lib/*-linux-gnu*) ldconfig ;;
    *) if grep -qxF "$LIBDIR" <<< "$dirs"; then ldconfig; fi ;;
  esac
}

# Removes the files of the manifest on standard input (not its folders).
remove_files() {
  local kind path
  while IFS=' ' read -r kind path; do
    if [ "$kind" = f ]; then
      rm -f -- "$D$path"
    fi
  done
}

if [ "$mode" = uninstall ]; then
  [ -f "$D$manifest" ] || die "no plsr installation here: $D$manifest does not exist (give \
make uninstall the PREFIX, LIBDIR and DESTDIR that make install had)"
  listed=$(cat "$D$manifest")
  remove_files <<< "$listed"
  # The folders the install made, deepest first, where nothing else is left.
  folders=$(sed -n 's/^d //p' <<< "$listed" | awk '{ print length($0) "\t" $0 }' | sort -rn | cut -f2-)
  while IFS= read -r dir; do
    if [ -n "$dir" ] && [ -d "$D$dir" ]; then
      rmdir --ignore-fail-on-non-empty -- "$D$dir"
    fi
  done <<< "$folders"$'\n'"$LIBDIR/plsr"$'\n'"$LIBDIR/cmake/plsr"
  refresh_ldconfig
  echo "uninstalled plsr from $D$PREFIX"
  exit 0
fi

# --- install ---
[ -n "${TARGET:-}" ] || die "TARGET is not set"
[ -n "${ABI_SINCE:-}" ] || die "ABI_SINCE is not set"
major=${VERSION%%.*}
real=libplsr.so.$VERSION
soname=libplsr.so.$major
for f in libplsr.so libplsr.a plsr; do
  [ -f "$TARGET/$f" ] || die "$TARGET/$f is missing: build first (make install builds it; or cargo build --release -p plsr-capi -p plsr-cli)"
done
for tool in objcopy readelf; do
  command -v $tool > /dev/null || die "$tool is missing (Debian package binutils)"
done
built_soname=$(readelf -d "$TARGET/libplsr.so" | sed -n 's/.*(SONAME).*\[\(.*\)\]/\1/p')
[ "$built_soname" = "$soname" ] || die "$TARGET/libplsr.so has soname '$built_soname', \
expected $soname (crates/capi/build.rs sets it; rebuild with cargo build --release)"

# An earlier install here is replaced: its files go, the folders it made are
# remembered as made by plsr.
new_manifest=$(mktemp)
trap 'rm -f "$new_manifest"' EXIT
if [ -f "$D$manifest" ]; then
  listed=$(cat "$D$manifest")
  remove_files <<< "$listed"
  grep '^d ' <<< "$listed" > "$new_manifest" || true
fi
# Makes a folder and each missing parent, recording those it made.
make_dir() {
  local dir=$1 path="" part
  local IFS=/
  for part in $dir; do
    [ -n "$part" ] || continue
    path="$path/$part"
    if [ ! -d "$D$path" ]; then
      mkdir -- "$D$path"
      echo "d $path" >> "$new_manifest"
    fi
  done
}
for dir in "$LIBDIR/plsr" "$LIBDIR/.debug" "$LIBDIR/pkgconfig" "$LIBDIR/cmake/plsr" \
  "$INCLUDEDIR" "$BINDIR/.debug"; do
  make_dir "$dir"
done
# The manifest is written before the files, so that a failed install can be
# uninstalled too.
record() {
  echo "f $1" >> "$new_manifest"
  cp "$new_manifest" "$D$manifest"
}
record "$manifest"

# The shared library: debug info into .debug/, a stripped copy linked to it.
record "$LIBDIR/.debug/$real.debug"
record "$LIBDIR/$real"
objcopy --only-keep-debug "$TARGET/libplsr.so" "$D$LIBDIR/.debug/$real.debug"
chmod 644 "$D$LIBDIR/.debug/$real.debug"
objcopy --strip-unneeded --remove-section=.comment \
  --add-gnu-debuglink="$D$LIBDIR/.debug/$real.debug" \
  "$TARGET/libplsr.so" "$D$LIBDIR/$real"
chmod 644 "$D$LIBDIR/$real"
record "$LIBDIR/$soname"
ln -sfn "$real" "$D$LIBDIR/$soname"
record "$LIBDIR/libplsr.so"
ln -sfn "$soname" "$D$LIBDIR/libplsr.so"
record "$LIBDIR/libplsr.a"
objcopy --strip-debug "$TARGET/libplsr.a" "$D$LIBDIR/libplsr.a"
chmod 644 "$D$LIBDIR/libplsr.a"

# The program (statically linked with the library: it needs no libplsr.so).
record "$BINDIR/.debug/plsr.debug"
record "$BINDIR/plsr"
objcopy --only-keep-debug "$TARGET/plsr" "$D$BINDIR/.debug/plsr.debug"
chmod 644 "$D$BINDIR/.debug/plsr.debug"
objcopy --strip-debug --add-gnu-debuglink="$D$BINDIR/.debug/plsr.debug" \
  "$TARGET/plsr" "$D$BINDIR/plsr"
chmod 755 "$D$BINDIR/plsr"

for h in plsr.h plsr.hpp; do
  record "$INCLUDEDIR/$h"
  install -m 644 "include/$h" "$D$INCLUDEDIR/$h"
done

# plsr.pc: paths under PREFIX are written as ${prefix}/…
under_prefix() {
  case "$1" in
    "$PREFIX"/*) echo "\${prefix}/${1#"$PREFIX"/}" ;;
    *) echo "$1" ;;
  esac
}
record "$LIBDIR/pkgconfig/plsr.pc"
sed -e "s|@PREFIX@|$PREFIX|" -e "s|@LIBDIR@|$(under_prefix "$LIBDIR")|" \
  -e "s|@INCLUDEDIR@|$(under_prefix "$INCLUDEDIR")|" -e "s|@VERSION@|$VERSION|" \
  plsr.pc.in > "$D$LIBDIR/pkgconfig/plsr.pc"

# The CMake package finds the library and headers relative to itself.
cmake_dir=$LIBDIR/cmake/plsr
lib_rel=$(realpath -s -m --relative-to="$cmake_dir" "$LIBDIR")
include_rel=$(realpath -s -m --relative-to="$cmake_dir" "$INCLUDEDIR")
bits=$(($(getconf LONG_BIT) / 8))
for f in plsrConfig plsrConfigVersion; do
  record "$cmake_dir/$f.cmake"
  sed -e "s|@VERSION@|$VERSION|g" -e "s|@MAJOR@|$major|g" -e "s|@ABI_SINCE@|$ABI_SINCE|g" \
    -e "s|@LIBDIR_REL@|$lib_rel|g" -e "s|@INCLUDEDIR_REL@|$include_rel|g" \
    -e "s|@SIZEOF_VOID_P@|$bits|g" "$f.cmake.in" > "$D$cmake_dir/$f.cmake"
done

refresh_ldconfig
echo "installed plsr $VERSION under $D$PREFIX (library in $D$LIBDIR, program in $D$BINDIR;"
echo "  make uninstall with the same PREFIX, LIBDIR and DESTDIR removes it)"
