"""Compare two `shrad render --export-patches` CSVs of one scene: patches matched by object
(in order), centre and normal; area-weighted relative L1 difference of radiosity (r+g+b)."""
import csv, sys, math, itertools
def read(p):
    return list(csv.DictReader(open(p)))
def objects(rows):
    out = {}
    order = []
    for r in rows:
        if r['object'] not in out:
            out[r['object']] = []; order.append(r['object'])
        out[r['object']].append(r)
    return [out[o] for o in order]
def vec(r, ks): return tuple(float(r[k]) for k in ks)
def lum(r): return sum(float(r[k]) for k in 'rgb')
a = objects(read(sys.argv[1]))
for other in sys.argv[2:]:
    b = objects(read(other))
    assert len(a) == len(b)
    num = den = 0.0; maxc = 0.0; fa = fb = 0.0; worst = 0.0; unmatched = 0
    for pa, pb in zip(a, b):
        grid = {}
        for r in pa:
            c = vec(r, ('cx','cy','cz'))
            grid.setdefault(tuple(round(x / 2) for x in c), []).append(r)
        oa = ob = 0.0
        for r in pb:
            c = vec(r, ('cx','cy','cz')); n = vec(r, ('nx','ny','nz'))
            k = tuple(round(x / 2) for x in c)
            best = None; bd = 1e30
            for d in itertools.product((-1,0,1), repeat=3):
                for q in grid.get(tuple(k[i]+d[i] for i in range(3)), ()):
                    if sum(x*y for x, y in zip(n, vec(q, ('nx','ny','nz')))) < 0.9: continue
                    dd = math.dist(c, vec(q, ('cx','cy','cz')))
                    if dd < bd: bd, best = dd, q
            A = float(r['area'])
            fb += A * lum(r); ob += A * lum(r)
            if best is None:
                unmatched += 1; continue
            maxc = max(maxc, bd)
            num += A * abs(lum(r) - lum(best)); den += A * lum(best)
        for r in pa:
            fa += float(r['area']) * lum(r); oa += float(r['area']) * lum(r)
        if oa > 0: worst = max(worst, abs(ob - oa) / oa)
    print(f"| {other.split('/')[-1]} | {100*num/den:.3f} % | {100*(fb-fa)/fa:+.3f} % | {100*worst:.3f} % | {maxc:.3f} | {unmatched} |")
