#!/usr/bin/env python3
"""Per ground-truth plane diagnosis of a planemap run (no numpy needed).

    tools/diag_planes.py WORKSPACE [OUT]     (OUT defaults to WORKSPACE/out-colmap)

For each gt plane: pixels, % depth within 1%, % label correct, the hypotheses matching it
(same tolerances as src/eval.rs) and the most frequent wrong label on it.
"""
import json, struct, sys, zlib, os
from collections import Counter, defaultdict

def read_png16(path):
    data = open(path, 'rb').read()
    assert data[:8] == b'\x89PNG\r\n\x1a\n'
    pos, idat, w = 8, b'', 0
    while pos < len(data):
        n, = struct.unpack('>I', data[pos:pos+4]); t = data[pos+4:pos+8]; c = data[pos+8:pos+8+n]
        if t == b'IHDR':
            w, h, bd, ct = struct.unpack('>IIBB', c[:10])
        elif t == b'IDAT':
            idat += c
        pos += 12 + n
    bpp = (bd // 8) * {0: 1, 2: 3, 4: 2, 6: 4}[ct]
    raw = zlib.decompress(idat); stride = w * bpp; out = bytearray(); prev = bytearray(stride)
    i = 0
    for _ in range(h):
        f = raw[i]; line = bytearray(raw[i+1:i+1+stride]); i += 1 + stride
        for x in range(stride):
            a = line[x-bpp] if x >= bpp else 0; b = prev[x]; cc = prev[x-bpp] if x >= bpp else 0
            if f == 1: line[x] = (line[x] + a) & 255
            elif f == 2: line[x] = (line[x] + b) & 255
            elif f == 3: line[x] = (line[x] + ((a + b) >> 1)) & 255
            elif f == 4:
                p = a + b - cc; pa, pb, pc = abs(p-a), abs(p-b), abs(p-cc)
                pr = a if pa <= pb and pa <= pc else (b if pb <= pc else cc)
                line[x] = (line[x] + pr) & 255
        out += line; prev = line
    if bd == 16 and ct == 0:
        return w, h, list(struct.unpack('>%dH' % (w*h), bytes(out)))
    if bd == 8 and ct == 0:
        return w, h, list(out)
    raise ValueError('unsupported png %s' % path)

def read_pfm(path):
    f = open(path, 'rb'); hdr = f.readline().strip(); w, h = map(int, f.readline().split())
    scale = float(f.readline()); n = w * h * (3 if hdr == b'PF' else 1)
    vals = struct.unpack(('<' if scale < 0 else '>') + 'f' * n, f.read(4 * n))
    # PFM rows are bottom-up
    rows = [vals[r*w:(r+1)*w] for r in range(h)][::-1]
    return w, h, [v for r in rows for v in r]

ws = sys.argv[1]; out = sys.argv[2] if len(sys.argv) > 2 else os.path.join(ws, 'out-colmap')
gt = json.load(open(os.path.join(ws, 'gt', 'planes.json')))
hyp = json.load(open(os.path.join(out, 'planes.json')))
names = sorted(os.listdir(os.path.join(ws, 'gt', 'planes')))
stats = defaultdict(lambda: [0, 0, 0, Counter()])
alld = []
per_view = []
for n in names:
    stem = n[:-4]
    _, _, gid = read_png16(os.path.join(ws, 'gt', 'planes', n))
    _, _, gz = read_pfm(os.path.join(ws, 'gt', 'depth', stem + '.pfm'))
    _, _, lab = read_png16(os.path.join(out, 'planemaps', n))
    _, _, z = read_pfm(os.path.join(out, 'depth', stem + '.pfm'))
    per_view.append((stem, gid, gz, lab, z))
    alld += [v for v in gz if v > 0]
alld.sort(); med = alld[len(alld)//2]
tol = 0.01 * med; cos_tol = 0.99862953  # cos 3°
def match(h):
    best = None
    for g in gt:
        c = sum(a*b for a, b in zip(h['normal'], g['normal']))
        d = abs(h['offset'] - g['offset']) if c >= 0 else abs(h['offset'] + g['offset'])
        if abs(c) >= cos_tol and d <= tol and (best is None or d < best[0]): best = (d, g['id'])
    return best[1] if best else 0
hm = [match(h) for h in hyp]
gt_hyps = defaultdict(list)
for i, m in enumerate(hm): gt_hyps[m].append(i)
nonplanar = [0, 0]
for stem, gid, gz, lab, z in per_view:
    for p in range(len(gz)):
        if gz[p] <= 0: continue
        ok = z[p] > 0 and abs(z[p]-gz[p]) <= 0.01*gz[p]
        if gid[p] == 0:
            nonplanar[0] += 1; nonplanar[1] += ok; continue
        s = stats[gid[p]]; s[0] += 1; s[1] += ok
        l = lab[p] - 1
        if l >= 0 and hm[l] == gid[p] and z[p] > 0: s[2] += 1
        else: s[3][l] += 1
print('median gt depth %.3f, match offset tol %.4f; %d hypotheses, %d unmatched: %s' % (
    med, tol, len(hyp), hm.count(0), [(i, round(hyp[i]['offset'], 3), hyp[i]['support']) for i, m in enumerate(hm) if m == 0]))
tot = sum(s[0] for s in stats.values())
for g in sorted(gt, key=lambda g: -stats[g['id']][0]):
    s = stats[g['id']]
    if s[0] == 0: continue
    wrong = s[3].most_common(2)
    print('%3d %-45.45s %7d (%4.1f%%) depth %5.1f%% label %5.1f%%  hyps %-10s wrong %s' % (
        g['id'], g['label'], s[0], 100*s[0]/tot, 100*s[1]/s[0], 100*s[2]/s[0],
        ','.join('%d(%d)' % (i, hyp[i]['support']) for i in gt_hyps.get(g['id'], [])) or 'NONE',
        ['%d->%s:%d' % (l, hm[l] if l >= 0 else '-', c) for l, c in wrong]))
if nonplanar[0]: print('non-planar gt pixels: %d, depth ok %.1f%%' % (nonplanar[0], 100*nonplanar[1]/nonplanar[0]))
