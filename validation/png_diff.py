"""Mean absolute pixel difference of two 8-bit PNGs relative to the mean pixel value."""
import zlib, struct, sys
def png(p):
    b = open(p, 'rb').read(); i = 8; idat = b''
    while i < len(b):
        n, t = struct.unpack('>I4s', b[i:i+8]); d = b[i+8:i+8+n]; i += 12 + n
        if t == b'IHDR': w, h, bd, ct = struct.unpack('>IIBB', d[:10])
        elif t == b'IDAT': idat += d
    bpp = {2: 3, 6: 4}[ct]; raw = zlib.decompress(idat); s = w * bpp; out = []; prev = bytearray(s)
    for y in range(h):
        f = raw[y*(s+1)]; line = bytearray(raw[y*(s+1)+1:(y+1)*(s+1)])
        for x in range(s):
            a = line[x-bpp] if x >= bpp else 0; u = prev[x]; c = prev[x-bpp] if x >= bpp else 0
            if f == 1: line[x] = (line[x] + a) & 255
            elif f == 2: line[x] = (line[x] + u) & 255
            elif f == 3: line[x] = (line[x] + (a + u) // 2) & 255
            elif f == 4:
                pa, pb, pc = abs(u - c), abs(a - c), abs(a + u - 2*c)
                line[x] = (line[x] + (a if pa <= pb and pa <= pc else u if pb <= pc else c)) & 255
        out.append(line); prev = line
    return [v for l in out for k, v in enumerate(l) if k % bpp < 3]
a = png(sys.argv[1])
for o in sys.argv[2:]:
    b = png(o)
    d = sum(abs(x - y) for x, y in zip(a, b)); m = sum(a)
    print(f"{o.split('/')[-1]}: mean |difference| {100*d/m:.3f} % of the mean pixel value, max {max(abs(x-y) for x,y in zip(a,b))}")
