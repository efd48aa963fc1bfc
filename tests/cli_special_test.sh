#!/usr/bin/env bash
# Command-line tests that need a shell (issue 11): exit 2 for every bad command line and
# --version; no progress bar unless stderr is a terminal; output to special files (a symlink
# to stdout, a FIFO, /dev/full, a symlink to a regular file); temporary files removed on
# SIGINT and SIGTERM; sizes and special input files refused early with a located message.
# Usage: cli_special_test.sh BASALT SOURCE_DIR WORK
set -uo pipefail
set -m  # job control: background jobs keep SIGINT (a non-interactive shell would ignore it)
BASALT=$1 SRC=$2 WORK=$3
rm -rf "$WORK" && mkdir -p "$WORK" && cd "$WORK" || exit 1
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
pass() { echo "ok: $*"; }

cat > good.pbrt <<'PBRT'
LookAt 0 0 -5  0 0 0  0 1 0
Camera "perspective" "float fov" [ 40 ]
Film "rgb" "integer xresolution" [ 16 ] "integer yresolution" [ 12 ] "string filename" "film.exr"
Sampler "independent" "integer pixelsamples" [ 2 ]
WorldBegin
LightSource "point" "rgb I" [ 10 10 10 ] "point3 from" [ 0 3 -3 ]
Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ]
Shape "sphere" "float radius" [ 1 ]
PBRT

# ---- --version ------------------------------------------------------------------------------
out=$("$BASALT" --version 2>&1); rc=$?
if [ $rc -eq 0 ] && [[ $out =~ ^basalt\ [0-9]+\.[0-9]+\.[0-9]+\ \(commit\ [0-9a-f]+(-dirty)?\)$ ]]; then
  pass "--version: $out"
else
  fail "--version: exit $rc, '$out'"
fi

# ---- exit 2 for every bad command line ------------------------------------------------------
# Every option of --help that takes a value: without its value; those with a type or a check
# (INT, FLOAT, a set of choices, --bump-step, --roulette): with a value they refuse. Free-text
# options (file names, --device) have no bad value at parse time.
check_exit2() {  # description, then the command line
  local what=$1; shift
  "$@" >/dev/null 2>err.txt; local rc=$?
  if [ $rc -ne 2 ]; then fail "$what: exit $rc, expected 2 ($(head -c 200 err.txt))"; return; fi
  if [ -e film.exr ] || [ -e bad.exr ]; then fail "$what: an output file was written"; fi
  checked=$((checked + 1))
}
for cmd in render study; do
  checked=0
  if [ $cmd = render ]; then pre=("$BASALT"); else pre=("$BASALT" study); fi
  help=$("${pre[@]}" --help) || fail "$cmd --help exits non-zero"
  while read -r name type; do
    check_exit2 "$cmd $name (no value)" "${pre[@]}" good.pbrt -o bad.exr "$name"
    if [[ $type =~ INT|FLOAT|UINT|\{ ]] || [ "$name" = --bump-step ] || [ "$name" = --roulette ]; then
      check_exit2 "$cmd $name zz%" "${pre[@]}" good.pbrt -o bad.exr "$name" "zz%"
    fi
  done < <(printf '%s\n' "$help" | sed -nE 's/^ +(-[a-z],)?(--[a-z-]+)(,--[a-z-]+)? ([A-Z]+[^ ]*).*/\2 \4/p')
  check_exit2 "$cmd unknown option" "${pre[@]}" good.pbrt --no-such-option
  check_exit2 "$cmd two scenes" "${pre[@]}" good.pbrt good.pbrt good.pbrt
  [ $checked -ge 15 ] && pass "$cmd: $checked bad command lines exit 2" ||
    fail "$cmd: only $checked bad command lines found in --help"
done
check_exit2 "render without a scene" "$BASALT" -o bad.exr
check_exit2 "--spp 0" "$BASALT" good.pbrt --spp 0
check_exit2 "--spp 2^24+1" "$BASALT" good.pbrt --spp 16777217

# ---- the progress bar only on a terminal ----------------------------------------------------
# A CPU render of a few seconds: stderr to a file carries no carriage return, a terminal does.
"$BASALT" "$SRC/scenes/cornell-box.pbrt" --device cpu --spp 24 -o bar.exr 2>bar-file.txt
if grep -q $'\r' bar-file.txt; then fail "progress bar drawn into a file"; else pass "no bar in a file"; fi
script -qec "'$BASALT' '$SRC/scenes/cornell-box.pbrt' --device cpu --spp 24 -o bar2.exr" /dev/null \
  >bar-tty.txt 2>&1 </dev/null
if grep -q $'\r\\[#*' bar-tty.txt && grep -q 'samples/s' bar-tty.txt; then pass "bar drawn on a terminal"
else fail "no progress bar on a terminal: $(head -c 300 bar-tty.txt)"; fi
# Its time estimate starts with the render, not at pipeline creation: no absurd first estimate.
left=$(grep -aoE '[0-9]+ s left' bar-tty.txt | head -1 | cut -d' ' -f1)
if [ -n "$left" ] && [ "$left" -lt 600 ]; then pass "first estimate $left s"; else fail "first estimate '$left' s left"; fi

# ---- special output files -------------------------------------------------------------------
# --stats /dev/stdout: the JSON reaches stdout (the old atomic writer replaced the link).
json=$("$BASALT" good.pbrt --device cpu -q -o film.exr --stats /dev/stdout); rc=$?
if [ $rc -eq 0 ] && [[ $json == *'"device": "cpu"'* ]] && [ -L /dev/stdout ]; then pass "--stats /dev/stdout"
else fail "--stats /dev/stdout: exit $rc, '$(printf %s "$json" | head -c 100)'"; fi
# A FIFO gets the image's bytes and stays a FIFO.
mkfifo pipe.exr
(cat pipe.exr > from-pipe.bin) &
reader=$!
timeout 60 "$BASALT" good.pbrt --device cpu -q -o pipe.exr; rc=$?
wait $reader
if [ $rc -eq 0 ] && [ -p pipe.exr ] && [ "$(head -c 4 from-pipe.bin | od -An -tx1 | tr -d ' ')" = 762f3101 ]; then
  pass "FIFO output: $(wc -c < from-pipe.bin) bytes of EXR"
else fail "FIFO output: exit $rc, fifo kept: $([ -p pipe.exr ] && echo yes || echo no)"; fi
# A write error (ENOSPC) is an error, exit 1, and /dev/full stays a device.
ln -s /dev/full full.png
"$BASALT" good.pbrt --device cpu -q -o full.png 2>err.txt; rc=$?
if [ $rc -eq 1 ] && grep -q "cannot write full.png: No space left" err.txt && [ -c /dev/full ]; then pass "/dev/full"
else fail "/dev/full: exit $rc: $(cat err.txt)"; fi
# A symlink to a regular file: the link stays, its target gets the image.
echo old > target.exr && ln -s target.exr link.exr
"$BASALT" good.pbrt --device cpu -q -o link.exr; rc=$?
if [ $rc -eq 0 ] && [ -L link.exr ] && [ "$(head -c 4 target.exr | od -An -tx1 | tr -d ' ')" = 762f3101 ]; then
  pass "symlink to a regular file kept"
else fail "symlink output: exit $rc"; fi
# An unwritable output is found before the render, and the message names it (no temporary).
"$BASALT" good.pbrt --device cpu -q -o no/such/dir/x.exr 2>err.txt; rc=$?
if [ $rc -eq 1 ] && grep -q "cannot write no/such/dir/x.exr" err.txt && ! grep -q tmp- err.txt; then
  pass "unwritable output refused up front"
else fail "unwritable output: exit $rc: $(cat err.txt)"; fi

# ---- signals while an image is written ------------------------------------------------------
for sig in INT TERM; do
  rm -f sig.exr sig.exr.tmp-*
  BASALT_TEST_SLOW_WRITE=20 "$BASALT" good.pbrt --device cpu -q -o sig.exr &
  pid=$!
  for _ in $(seq 100); do compgen -G "sig.exr.tmp-*" >/dev/null && break; sleep 0.1; done
  compgen -G "sig.exr.tmp-*" >/dev/null || fail "SIG$sig: no temporary file appeared"
  kill -$sig $pid; wait $pid; rc=$?
  left=$(compgen -G "sig.exr*" | tr '\n' ' ')
  if [ $rc -gt 128 ] && [ -z "$left" ]; then pass "SIG$sig while writing: exit $rc, nothing left"
  else fail "SIG$sig while writing: exit $rc, left: '$left'"; fi
done

# ---- sizes and special input files, refused early and located -------------------------------
expect_error() {  # description, pattern, scene text
  printf '%s\n' "$3" > sized.pbrt
  local t0=$SECONDS
  timeout 60 "$BASALT" sized.pbrt --device "${DEVICE:-cpu}" -q -o sized.exr 2>err.txt; local rc=$?
  if [ $rc -eq 1 ] && grep -qE "$2" err.txt && [ ! -e sized.exr ] && [ $((SECONDS - t0)) -lt 30 ]; then
    pass "$1"
  else fail "$1: exit $rc after $((SECONDS - t0)) s: $(head -c 300 err.txt)"; fi
}
head3='LookAt 0 0 -5 0 0 0 0 1 0
Camera "perspective"'
film8='Film "rgb" "integer xresolution" [ 8 ] "integer yresolution" [ 8 ]'
expect_error "2^30 x 2^30 film on the CPU" '^sized.pbrt:3:[0-9]+: error: xresolution 1073741824 exceeds' \
  "$head3
Film \"rgb\" \"integer xresolution\" [ 1073741824 ] \"integer yresolution\" [ 1073741824 ]
WorldBegin
Shape \"sphere\""
DEVICE=lavapipe expect_error "8192 x 8192 film on lavapipe (512 MiB)" \
  '^sized.pbrt:3:[0-9]+: error: a 8192 x 8192 film needs 1073741824 bytes' \
  "$head3
Film \"rgb\" \"integer xresolution\" [ 8192 ] \"integer yresolution\" [ 8192 ]
WorldBegin
Shape \"sphere\""
expect_error "65536 x 65536 film on the CPU" '^sized.pbrt:3:[0-9]+: error: a 65536 x 65536 film needs' \
  "$head3
Film \"rgb\" \"integer xresolution\" [ 65536 ] \"integer yresolution\" [ 65536 ]
WorldBegin
Shape \"sphere\""
expect_error "negative light scale" '^sized.pbrt:5:[0-9]+: error: light "scale" must be finite and not negative' \
  "$head3
$film8
WorldBegin
LightSource \"point\" \"float scale\" -2
Shape \"sphere\""
expect_error "Include /dev/zero" '^sized.pbrt:5:1: error: cannot read included file "/dev/zero": is a device' \
  "$head3
$film8
WorldBegin
Include \"/dev/zero\""
mkfifo in.fifo
expect_error "Include of a FIFO" '^sized.pbrt:5:1: error: cannot read included file ".*in.fifo": is a FIFO' \
  "$head3
$film8
WorldBegin
Include \"in.fifo\""
expect_error "plymesh /dev/zero" '^sized.pbrt:5:1: error: PLY file "/dev/zero": cannot read PLY file: is a device' \
  "$head3
$film8
WorldBegin
Shape \"plymesh\" \"string filename\" \"/dev/zero\""
printf 'ply\nformat binary_little_endian 1.0\nelement junk 9223372036854775807\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n' > noprop.ply
head -c 36 /dev/zero >> noprop.ply && printf '\003\000\000\000\000\001\000\000\000\002\000\000\000' >> noprop.ply
printf '%s\n%s\nWorldBegin\nShape "plymesh" "string filename" "noprop.ply"\n' "$head3" "$film8" > noprop.pbrt
timeout 30 "$BASALT" noprop.pbrt --device cpu -q -o noprop.exr 2>err.txt; rc=$?
if [ $rc -eq 0 ]; then pass "PLY element without properties and 2^63-1 items: read at once"
else fail "PLY element without properties: exit $rc: $(cat err.txt)"; fi
printf 'ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 20000000\nproperty list uchar int vertex_indices\nend_header\n' > big.ply
head -c 1000000 /dev/zero >> big.ply
DEVICE=lavapipe expect_error "20M-face PLY header on lavapipe" \
  'error: PLY file "big.ply": the header declares 20000000 face elements' \
  "$head3
$film8
WorldBegin
Shape \"plymesh\" \"string filename\" \"big.ply\""
expect_error "PLY counts beyond the file size" 'error: PLY file "big.ply": truncated PLY file: the header' \
  "$head3
$film8
WorldBegin
Shape \"plymesh\" \"string filename\" \"big.ply\""

echo "$failures failure(s)"
[ $failures -eq 0 ]
