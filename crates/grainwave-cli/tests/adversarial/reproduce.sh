#!/usr/bin/env bash
# The reproducers of the hardening issue, run against BIN (default target/release/grainwave) from
# the repository root: one table row per case, "| case | exit | first line of the message | size |"
# (docs/hardening.md). Scratch files go to W (default a new temporary directory).
cd "$(dirname "$0")/../../../.."
set -u
BIN=${BIN:-target/release/grainwave}
ADV=crates/grainwave-cli/tests/adversarial
W=${W:-$(mktemp -d)}
mkdir -p "$W"
gw() { timeout 120 "$BIN" --threads 1 --quiet "$@"; }
row() { # name, then command...
    local name=$1; shift
    local err code
    err=$("$@" 2>&1 >/dev/null); code=$?
    local first
    # a config error is a report whose first line is its code; its message is the `×` line
    first=$( { printf '%s\n' "$err" | grep -m1 '×' || printf '%s\n' "$err" | grep -v '^\s*$' | head -1; } | sed 's/^ *× *//' | cut -c1-220 | sed 's/|/\\|/g')
    [ -z "$first" ] && first="(no message)"
    echo "| $name | $code | ${first} | $(printf '%s' "$err" | wc -c) B |"
}
echo "| case | exit | first line of stderr | stderr size |"
echo "|---|---|---|---|"
row "sim grains.count = 4e9 (check)" gw check $ADV/sim-grains-4e9.toml
row "sim domain.size = [20, 4294967296] (check)" gw check $ADV/sim-domain-2e32.toml
row "e1 samples = 1e9 (check)" gw check $ADV/e1-samples-1e9.toml
row "e1 samples = 1e9 (check --allow-large)" gw --allow-large check $ADV/e1-samples-1e9.toml
row "e1 heights = [1e9] (check)" gw check $ADV/e1-heights-1e9.toml
row "e1 heights = [1e9] (run)" gw run $ADV/e1-heights-1e9.toml --out $W/h
row "e3 profile_step = 1e-12 (check)" gw check $ADV/e3-profile-step-1e-12.toml
row "e3 profile_step = 1e-12 (run)" gw run $ADV/e3-profile-step-1e-12.toml --out $W/ps
# LAMMPS data files through `grainwave bench` (the command that reads them)
mkdir -p $W/lmp-atoms $W/lmp-line
printf 'LAMMPS data file\n\n1000000000000 atoms\n1 atom types\n\n0 4 xlo xhi\n0 4 ylo yhi\n0 4 zlo zhi\n\nAtoms # sphere\n\n' | gzip > $W/lmp-atoms/pack3d_062.data.gz
python3 - "$W/lmp-line/pack3d_062.data.gz" <<'PY'
import gzip, sys
with gzip.open(sys.argv[1], "wb", compresslevel=1) as f:
    f.write(b"LAMMPS data file\n\n2 atoms\n")
    chunk = b"7" * (1 << 20)
    for _ in range(200): f.write(chunk)
PY
row "LAMMPS file declaring 1e12 atoms (bench)" gw bench hooke3d --dir $W/lmp-atoms --steps 1
row "LAMMPS gzip file, one 200 MB line (bench)" /usr/bin/time -f "peak RSS %M kB" "$BIN" --threads 1 --quiet bench hooke3d --dir $W/lmp-line --steps 1
row "sim duplicate wall name (check)" gw check $ADV/sim-duplicate-wall.toml
row "e1 max_acceleration = 1.5 (check)" gw check $ADV/e1-max-acceleration-1.5.toml
row "e1 max_acceleration = 1.5 (run)" gw run $ADV/e1-max-acceleration-1.5.toml --out $W/ma
row "e1 step_limit = 30 (run: every sample fails)" gw run $ADV/e1-step-limit.toml --out $W/sl
row "e1 pressures = [1e308] (check)" gw check $ADV/e1-pressure-1e308.toml
row "sim normal_stiffness = 5e-324 (check)" gw check $ADV/sim-normal-stiffness-5e-324.toml
row "e1 pulse = [] (check)" gw check $ADV/e1-pulse-array.toml
# two runs into one directory: the second while the first holds the lock
Q=$ADV/quick.toml
sed 's/step_limit = 2000/step_limit = 200000/' $Q > $W/long.toml
( gw run $W/long.toml --out $W/two >/dev/null 2>&1 ) & pid=$!
sleep 2
row "two runs into one directory (second, concurrent)" gw run $Q --out $W/two
kill $pid 2>/dev/null; wait $pid 2>/dev/null
rm -rf $W/two
gw run $Q --out $W/used >/dev/null 2>&1
row "re-run into a used directory" gw run $Q --out $W/used
touch $W/used/grains-999999.vtp
row "re-run with --overwrite (stale file removed: see next line)" gw run $Q --out $W/used --overwrite
echo "| stale grains-999999.vtp after --overwrite | $( [ -e $W/used/grains-999999.vtp ] && echo present || echo removed ) | | |"
sed 's/^seed = 3/seed = 4/' $Q > $W/seed4.toml
gw run $W/seed4.toml --out $W/other >/dev/null 2>&1
cp $W/other/checkpoint.gwck $W/used/checkpoint.gwck
row "resume with a checkpoint of another run (other seed)" gw resume $W/used
gw run $ADV/e1-step-limit.toml --out $W/e1ck >/dev/null 2>&1
gw run $Q --out $W/kind >/dev/null 2>&1
cp $W/e1ck/checkpoint.gwck $W/kind/checkpoint.gwck 2>/dev/null
row "resume with a checkpoint of another experiment (e1 into simulation)" gw resume $W/kind
gw run $Q --out $W/app >/dev/null 2>&1
printf 'xxxxxxxx' >> $W/app/checkpoint.gwck
row "checkpoint with 8 bytes appended (resume)" gw resume $W/app
gw run $Q --out $W/cut >/dev/null 2>&1
head -c -5 $W/cut/checkpoint.gwck > $W/cut/ck && mv $W/cut/ck $W/cut/checkpoint.gwck
row "checkpoint with its last 5 bytes cut (resume)" gw resume $W/cut
row "e2 replay blow-up (run)" gw run $ADV/e2-replay-blow-up.toml --out $W/e2b
echo "| e2 blow-up: run.log has it | $(grep -c 'failed:' $W/e2b/run.log) line(s) | $(grep -m1 'failed:' $W/e2b/run.log | cut -c1-160) | |"
echo "| e2 blow-up: inspect | | $("$BIN" inspect $W/e2b 2>&1 | grep -m1 -i 'fail' | cut -c1-160) | |"
row "e2 blow-up: resume" gw resume $W/e2b
row "e3 forces = 1e12, every run blows up (run)" gw run $ADV/e3-forces-1e12.toml --out $W/e3b
echo "| e3 blow-up: run.log has it | $(grep -c 'failed:' $W/e3b/run.log) line(s) | $(grep -m1 'failed:' $W/e3b/run.log | cut -c1-160) | |"
echo "| e3 blow-up: inspect | | $("$BIN" inspect $W/e3b 2>&1 | grep -m1 -i 'fail' | cut -c1-160) | |"
row "e3 blow-up: resume" gw resume $W/e3b
python3 - $ADV/e1-pressure-1e308.toml $W/enum.toml <<'PY'
import sys
t = open(sys.argv[1]).read().replace('kind = "sphere2d"', 'kind = "' + "q" * (1 << 20) + '"')
open(sys.argv[2], "w").write(t)
PY
row "1 MB bad enum value (check)" gw check $W/enum.toml
row "[samples] written as a table (check)" gw check $ADV/e1-samples-table.toml
row "repeated table header (check)" gw check $ADV/e1-repeated-table.toml
row "walls[3].speed.times not increasing (check)" gw check $ADV/sim-wall-speed-times.toml
touch $W/afile
row "uncreatable output directory (run --out FILE/x)" gw run $Q --out $W/afile/x
row "read-only existing output directory (run --out /sys/kernel)" gw run $Q --out /sys/kernel
row "LAMMPS file with a bad line (bench)" bash -c "mkdir -p $W/lmp-bad && printf 'LAMMPS data file\n\n2 atoms\n1 atom types\n\n0 4 xlo xhi\n0 4 ylo yhi\n0 4 zlo zhi\n\nAtoms # sphere\n\n1 1 1 1 one 1 1\n2 1 1 1 2 2 2\n' | gzip > $W/lmp-bad/pack3d_062.data.gz && $BIN --threads 1 --quiet bench hooke3d --dir $W/lmp-bad --steps 1"
sed 's/^\[placement\]/[placement]\nmethod = "lattice"\nspacing = 0.5/' $Q > $W/overlap.toml
row "initial overlap: lattice spacing 0.5 d (check)" gw check $W/overlap.toml
row "initial overlap: lattice spacing 0.5 d (run)" gw run $W/overlap.toml --out $W/ov
# second probe (docs/hardening.md, "Second probe"): check = run, exit codes, messages
for f in sim-not-before-nan e1-chain-tof-nan e3-lattice-horizontal-3 e3-bracket-3 sim-origin-outside-region \
    e2-normal_stiffness-5e-324 e2-rolling_stiffness-1e308 e2-wall_mass-1e308 e2-gravity-1e308 e2-source-dir-missing \
    e2-replay-name-300 e2-top-pulse-without-piston e2-checkpoint-strain-5e-324 e3-duplicate-widths e3-friction-5e-324 \
    e3-forces-5e-324 e3-response-max-acceleration-1e308 e1-chain-stiffness-1e308 e1-chain-spacing-1e308 \
    e1-transits-1e308 e3-lattice-tangential_ratios-1e308 sim-piston-tiny-mass-huge-force sim-velocity-table-1e308; do
    row "$f (check)" gw check $ADV/$f.toml
done
row "e2 preparation without equilibrium (run)" gw run $ADV/e2-no-equilibrium.toml --out $W/noeq
row "LAMMPS tilt xy = nan (bench)" gw bench hooke3d --dir $ADV/lmp-tilt-nan --steps 2
row "LAMMPS angular velocity nan (bench)" gw bench hooke3d --dir $ADV/lmp-omega-nan --steps 2
row "bench --shear nan" gw bench hooke3d --dir $ADV/lmp-tilt-nan --shear nan
gw run $Q --out $W/unfinished >/dev/null 2>&1 && rm $W/unfinished/summary.json $W/unfinished/series.npz
row "plot of an unfinished run" gw plot $W/unfinished
