"""Instructions executed by whole bakes, for A/B comparisons of speed changes on a noisy machine
(docs/benchmarks.md, issue 16, session 53).

On the shared 2-core machines the CPU time (user + sys) of the same binary on the same input can
move by 10-40 % from one run to the next; the instruction count that valgrind's cachegrind reports
for a one-thread bake repeats to within 0.0001 %. So a change that claims to save a few per cent
is measured here, and the CPU time of the result is measured after, interleaved, as the targets
ask. Instructions are not time (memory stalls differ), but they rank changes to the same code.

Usage (a measurement, not a test; needs valgrind, Debian package `valgrind`):
    python3 tools/bench-scripts/instructions.py MODEL --bin A --bin B [--seed 1 --seed 2] [-- BAKE ARGS...]
e.g.
    python3 tools/bench-scripts/instructions.py stanford-bunny.obj --bin /tmp/old --bin target/release/spherebake -- --preset fast
Prints one JSON row per (binary, seed): the instructions executed and the bake's E. Under valgrind
a bake takes 15-20x its normal time."""
import json, os, re, subprocess, sys, tempfile


def instructions(binary, model, seed, extra, out):
    cmd = ['valgrind', '--tool=cachegrind', '--cache-sim=no', '--cachegrind-out-file=/dev/null',
           binary, 'bake', model, '-o', out, '--force', '--json', '--seed', str(seed)] + extra
    env = dict(os.environ, RAYON_NUM_THREADS='1')
    p = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if p.returncode != 0:
        sys.exit(f'{binary}: bake failed: {p.stderr.strip().splitlines()[-1:]}')
    m = re.search(r'I\s+refs:\s+([\d,]+)', p.stderr)
    if not m:
        sys.exit(f'{binary}: no instruction count in valgrind output')
    e = json.loads(p.stdout)['assets'][0]['outside_ratio_e']
    return int(m.group(1).replace(',', '')), e


def main():
    args = sys.argv[1:]
    extra = []
    if '--' in args:
        i = args.index('--')
        args, extra = args[:i], args[i + 1:]
    if not args:
        sys.exit(__doc__)
    model, bins, seeds = args[0], [], []
    rest = args[1:]
    while rest:
        flag, value, rest = rest[0], rest[1] if len(rest) > 1 else None, rest[2:]
        if flag == '--bin' and value:
            bins.append(value)
        elif flag == '--seed' and value:
            seeds.append(int(value))
        else:
            sys.exit(f'unknown argument {flag!r}\n{__doc__}')
    bins = bins or ['target/release/spherebake']
    seeds = seeds or [1]
    with tempfile.TemporaryDirectory() as d:
        for seed in seeds:
            for b in bins:
                n, e = instructions(b, model, seed, extra, os.path.join(d, 'out.sphb'))
                print(json.dumps({'binary': b, 'model': model, 'seed': seed, 'args': extra,
                                  'instructions': n, 'e': e}))


if __name__ == '__main__':
    main()
