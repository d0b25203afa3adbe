#!/usr/bin/env bash
# Issue 39's figures on a machine with many cores, two engines side by side in one
# run (benches/README.md, "16 cores"): the kernel and end-to-end rates at 1 … N
# threads, whole `clearance run` processes into /dev/shm at 2 and N threads (wall,
# CPU, peak memory and page faults), the 8.7 M-row sweep of the issue, and the new
# engine under two settings of glibc's allocator (larger first heaps, and those on
# transparent huge pages).
#
#   scripts/scaling_many_cores.sh NEW_BIN OLD_BIN OUT_DIR [THREADS]
#
# NEW_BIN and OLD_BIN are release binaries (OLD_BIN may be the same as NEW_BIN);
# every table goes to OUT_DIR/summary.txt and to stdout, the raw output beside it.
# Needs python3 (wall, CPU, peak RSS and page faults of each process) and about 6 GB in
# /dev/shm; took 109 s on a 16-core Xeon before the allocator rounds were added
# (nine more runs of a second or so).
set -u
NEW=$1 OLD=$2 OUT=$3 N=${4:-$(nproc)}
mkdir -p "$OUT"
export TMPDIR=/dev/shm
work=$(mktemp -d /dev/shm/scaling.XXXXXX)
trap 'rm -rf "$work"' EXIT
here=$(cd "$(dirname "$0")/.." && pwd)
summary="$OUT/summary.txt"
say() { echo "$*" | tee -a "$summary"; }

say "# $(date -u +%FT%TZ), $(nproc) CPUs; new $("$NEW" --version), old $("$OLD" --version)"
lscpu > "$OUT/lscpu.txt" 2>&1
grep -E "Model name|^CPU\(s\)|Thread|Flags" "$OUT/lscpu.txt" | sed 's/^Flags:.*\(avx2\).*\(avx512f\).*/Flags: avx2 avx512f …/' | tee -a "$summary"

# Wall seconds, CPU seconds, peak RSS (MiB) and minor page faults of one process,
# quiet.
timed() {
    python3 - "$@" <<'EOF'
import resource, subprocess, sys, time
t = time.perf_counter()
rc = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE).returncode
wall = time.perf_counter() - t
ru = resource.getrusage(resource.RUSAGE_CHILDREN)
print(f"{wall:.3f} {ru.ru_utime + ru.ru_stime:.2f} {ru.ru_maxrss / 1024:.0f} faults={ru.ru_minflt} rc={rc}")
EOF
}

# 1. bench --scaling, new then old, standard columns, then minimal and none.
counts="1,2,4,8,$N"
[ "$N" -le 8 ] && counts="1,2,4,$N"
for cols in standard minimal none; do
    for which in new old; do
        bin=$NEW; [ $which = old ] && bin=$OLD
        say "## bench --scaling --columns $cols ($which)"
        tc=$counts; [ $cols != standard ] && tc="2,$N"
        "$bin" bench --scaling --thread-counts "$tc" --repeat 3 --columns $cols > "$OUT/scaling_${cols}_$which.txt" 2>&1
        grep -E "^\s*[0-9]+\s|thread|kernel" "$OUT/scaling_${cols}_$which.txt" | tee -a "$summary"
    done
done

# Alternated rounds of `clearance run JOB` by both engines into /dev/shm:
#   runs JOB ROUNDS "THREAD COUNTS" [RUN FLAGS...]
runs() {
    local job=$1 rounds=$2 counts=$3
    shift 3
    for round in $(seq "$rounds"); do
        for t in $counts; do
            for which in new old; do
                bin=$NEW; [ $which = old ] && bin=$OLD
                say "$which threads=$t round=$round $*: $(timed "$bin" run "$job" --out "$work/o" --threads "$t" --quiet "$@")"
                rm -rf "$work/o"
            done
        done
    done
}

# 2. Whole processes, grid_2d at 2 × 2 its samples (1.6 M poses).
sed 's/n = 633/n = 1266/g' "$here/benches/suite/grid_2d.toml" > "$work/grid_2d_x4.toml"
say "## clearance run grid_2d at 1266 x 1266 into /dev/shm: wall s, CPU s, peak MiB, faults"
runs "$work/grid_2d_x4.toml" 3 "2 $N"
runs "$work/grid_2d_x4.toml" 2 "$N" --columns minimal

# 3. The issue's sweep: 8 × 301 × 301 poses, 4 masses × 3 r_radial, 8.7 M rows.
sed -e 's/n = 4 }/n = 8 }/' -e 's/n = 121/n = 301/g' "$here/benches/suite/sweep_masses_clearances_12.toml" > "$work/sweep_8m.toml"
say "## 8.7 M-row sweep into /dev/shm: wall s, CPU s, peak MiB, faults"
runs "$work/sweep_8m.toml" 2 "$N"
runs "$work/sweep_8m.toml" 1 2

# 4. The new engine's allocator, alternated at N threads on grid_2d at 1.6 M poses:
# as it is; each thread's first heap 32 MiB (else its heap grows by mprotect, often a
# page at a time: about 1 000 calls a run on 2 cores, each holding the process's
# memory map against every other thread's page faults); the same on transparent huge
# pages (a third of the page faults on 2 cores). benches/README.md, "What limits it
# now".
say "## allocator settings, new engine, grid_2d at 1266 x 1266, $N threads: wall s, CPU s, peak MiB, faults"
for round in 1 2 3; do
    for tunables in "" glibc.malloc.top_pad=33554432 glibc.malloc.hugetlb=1:glibc.malloc.top_pad=33554432; do
        say "GLIBC_TUNABLES=$tunables round=$round: $(GLIBC_TUNABLES=$tunables timed "$NEW" run "$work/grid_2d_x4.toml" --out "$work/o" --threads "$N" --quiet)"
        rm -rf "$work/o"
    done
done
say "# done $(date -u +%FT%TZ)"
