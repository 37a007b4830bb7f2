"""MorphIt port vs spherebake, side by side (docs/benchmarks.md, issue 16): CPU (user+sys of a child process) and
wall, then E and coverage by `spherebake eval` on both sphere sets (the port's written as a spheres-only .sphb per
the format spec), and the port's spheres grown at least cost until they bound.

Usage (a measurement, not a test; needs `pip install morphit-rs numpy` in MORPHIT_PYTHON's environment):
    MORPHIT_PYTHON=venv/bin/python python3 tools/bench-scripts/morphit_side_by_side.py MODEL.obj 64 MorphIt-B
    python3 tools/bench-scripts/morphit_side_by_side.py MODEL.obj 64 fast      # spherebake --preset fast
Prints one JSON row. Environment: SPHEREBAKE (binary, default target/release/spherebake), OUT (scratch folder).
The growth step imports numpy in this interpreter: run the script itself with MORPHIT_PYTHON too."""
import json, os, struct, subprocess, sys, time, zlib, resource
SB = os.environ.get('SPHEREBAKE', 'target/release/spherebake')
OUT = os.environ.get('OUT', '/tmp/morphit-side-by-side')
os.makedirs(OUT, exist_ok=True)
def write_sphb(path, centers, radii):
    n = len(radii)
    body = struct.pack('<I12x', n) + b''.join(struct.pack('<4f', *c, r) for c, r in zip(centers, radii))
    sec_off = 64 + 32
    sec_off = (sec_off + 15) // 16 * 16
    end = sec_off + len(body)
    size = (end + 15) // 16 * 16
    entry = struct.pack('<IIQQII', 1, 0, sec_off, len(body), zlib.crc32(body), 0)
    head = b'\x89SPHB\r\n\x1a' + struct.pack('<HHIIIQQI', 1, 0, 64, 0, 1, 64, size, zlib.crc32(entry))
    head += struct.pack('<I', zlib.crc32(head)) + bytes(16)
    out = bytearray(size)
    out[:64] = head; out[64:96] = entry; out[sec_off:end] = body
    open(path, 'wb').write(out)
def timed(cmd):
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN); t0 = time.time()
    p = subprocess.run(cmd, capture_output=True, text=True)
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0: print(p.stderr, file=sys.stderr)
    return p, (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime), time.time() - t0
def ev(sphb, model):
    p = subprocess.run([SB, 'eval', sphb, model, '--json', '--surface-samples', '200000'], capture_output=True, text=True)
    if p.returncode != 0: return p.stderr.strip()
    return json.loads(p.stdout)
model, n, preset = sys.argv[1], int(sys.argv[2]), sys.argv[3]
name = os.path.splitext(os.path.basename(model))[0]
if preset.startswith('MorphIt'):
    code = f"""
import morphit_rs as mi, json
mi.set_num_threads(1)
m = mi.Mesh.load({model!r}); c = mi.Config.preset({preset!r}, num_spheres={n}, seed=1)
r = mi.pack(m, c)
json.dump({{'c': [list(map(float, x)) for x in r.centers], 'r': list(map(float, r.radii))}}, open('{OUT}/{name}-{preset}.json', 'w'))
"""
    p, cpu, wall = timed([os.environ.get('MORPHIT_PYTHON', sys.executable), '-c', code])
    d = json.load(open(f'{OUT}/{name}-{preset}.json'))
    write_sphb(f'{OUT}/{name}-{preset}.sphb', d['c'], d['r'])
    e = ev(f'{OUT}/{name}-{preset}.sphb', model)
else:
    p, cpu, wall = timed([SB, 'bake', model, '--spheres', str(n), '--preset', preset, '-o', f'{OUT}/{name}-{preset}.sphb', '-q', '--force'])
    e = ev(f'{OUT}/{name}-{preset}.sphb', model)
def short(e):
    return {k: round(e[k], 4) for k in ('outside_ratio_e', 'surface_coverage', 'max_gap_relative')} if isinstance(e, dict) else e
row = {'model': name, 'spheres': n, 'method': preset, 'cpu_s': round(cpu, 3), 'wall_s': round(wall, 3), 'eval': short(e)}
if preset.startswith('MorphIt') and isinstance(e, dict) and e['surface_coverage'] < 1.0:
    # Grown until bounding: 1M area-weighted surface points (seeded); each uncovered point grows the sphere whose
    # surface is nearest to it until it reaches the point (the cheapest growth that covers it), then E and coverage
    # by `spherebake eval` on its own, independent samples.
    import numpy as np
    V, F = [], []
    for line in open(model):
        t = line.split()
        if t and t[0] == 'v': V.append([float(x) for x in t[1:4]])
        elif t and t[0] == 'f':
            idx = [int(x.split('/')[0]) - 1 for x in t[1:]]
            for k in range(1, len(idx) - 1): F.append([idx[0], idx[k], idx[k + 1]])
    V, F = np.array(V), np.array(F)
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    rng = np.random.default_rng(7)
    tri = rng.choice(len(F), size=1_000_000, p=area / area.sum())
    u, v = rng.random(1_000_000), rng.random(1_000_000)
    flip = u + v > 1; u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    pts = a[tri] + (b[tri] - a[tri]) * u[:, None] + (c[tri] - a[tri]) * v[:, None]
    d = json.load(open(f'{OUT}/{name}-{preset}.json'))
    C, R = np.array(d['c']), np.array(d['r'])
    for chunk in np.array_split(np.arange(len(pts)), 50):
        q = pts[chunk]
        dist = np.linalg.norm(q[:, None, :] - C[None, :, :], axis=2)
        gap = dist - R[None, :]
        out = (gap > 0).all(axis=1)
        j = np.argmin(gap[out], axis=1)
        np.maximum.at(R, j, dist[out][np.arange(len(j)), j] * 1.000001)
    write_sphb(f'{OUT}/{name}-{preset}-grown.sphb', C.tolist(), R.tolist())
    row['grown'] = short(ev(f'{OUT}/{name}-{preset}-grown.sphb', model))
print(json.dumps(row))
