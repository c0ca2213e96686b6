#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# tools/dev.sh (issue 28, point 9): `deps` installs a missing package with apt-get as root and
# through sudo otherwise (README's first command has no sudo: a root container has none), and
# without sudo prints the apt-get line and exits 1; the demo's targets compile no test.
# Fake dpkg-query (one package missing), id, sudo and apt-get in a PATH of their own record what
# dev.sh runs.   check_dev_sh.sh SOURCE_DIR BUILD_DIR WORK_DIR
set -euo pipefail
src=$1 build=$2 work=$3
rm -rf "$work"
mkdir -p "$work/bin" "$work/nosudo"
log=$work/log
for tool in bash grep dirname env nproc cat; do
    ln -s "$(command -v $tool)" "$work/nosudo/$tool"
done
cat > "$work/nosudo/dpkg-query" <<'EOS'
#!/bin/bash
[ "${!#}" = libcmocka-dev ] && exit 1
printf 'install ok installed'
EOS
printf '#!/bin/bash\necho "${FAKE_UID:-0}"\n' > "$work/nosudo/id"
printf '#!/bin/bash\necho "apt-get $*" >> "%s"\n' "$log" > "$work/nosudo/apt-get"
printf '#!/bin/bash\necho "sudo $*" >> "%s"\nexec "$@"\n' "$log" > "$work/bin/sudo"
chmod +x "$work/nosudo/"* "$work/bin/sudo"
fail() { echo "FAIL: $*"; [ -f "$log" ] && sed 's/^/  log: /' "$log"; exit 1; }

# As root: apt-get itself, no sudo.
rm -f "$log"
FAKE_UID=0 PATH="$work/bin:$work/nosudo" "$src/tools/dev.sh" deps > "$work/out" 2>&1 ||
    fail "deps as root: $(cat "$work/out")"
grep -q "^apt-get install .*libcmocka-dev" "$log" || fail "as root: no apt-get install"
grep -q "^sudo" "$log" && fail "as root: sudo used"
# Not root, sudo there: through sudo.
rm -f "$log"
FAKE_UID=1000 PATH="$work/bin:$work/nosudo" "$src/tools/dev.sh" deps > "$work/out" 2>&1 ||
    fail "deps as a user: $(cat "$work/out")"
grep -q "^sudo apt-get update" "$log" || fail "as a user: no sudo apt-get update"
grep -q "^sudo env DEBIAN_FRONTEND=noninteractive apt-get install .*libcmocka-dev" "$log" ||
    fail "as a user: no sudo apt-get install"
# Not root, no sudo: the line to run, exit 1, nothing installed.
rm -f "$log"
if FAKE_UID=1000 PATH="$work/nosudo" "$src/tools/dev.sh" deps > "$work/out" 2>&1; then
    fail "deps without sudo succeeded"
fi
grep -q "apt-get install -y libcmocka-dev" "$work/out" || fail "no apt-get line: $(cat "$work/out")"
[ -f "$log" ] && fail "without sudo: something was run"
echo "deps: apt-get as root, sudo apt-get as a user, the apt-get line without sudo"

# The demo's targets: what ninja would run for them (from scratch) compiles nothing of tests/.
targets=$(sed -n 's/^demo_targets="\(.*\)"$/\1/p' "$src/tools/dev.sh")
[ -n "$targets" ] || fail "no demo_targets in dev.sh"
ninja -C "$build" -t commands $targets > "$work/demo_commands"
ninja -C "$build" -t commands all > "$work/all_commands"
if grep -q "$src/tests/" "$work/demo_commands"; then
    fail "the demo's targets ($targets) compile tests: $(grep -m3 "$src/tests/" "$work/demo_commands")"
fi
grep -q "defsim_newton_cholmod\|newton_cholmod" "$work/demo_commands" ||
    fail "the demo's targets do not build the newton_cholmod module its second scene uses"
echo "demo ($targets): $(wc -l < "$work/demo_commands") build commands of $(wc -l < "$work/all_commands") for every target"
