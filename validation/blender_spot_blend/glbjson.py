import json, struct, sys
def glb_json(p):
    b = open(p, 'rb').read()
    n, t = struct.unpack_from('<II', b, 12)
    return json.loads(b[20:20+n])
if __name__ == '__main__':
    j = glb_json(sys.argv[1])
    for k in ('asset','extensionsUsed','extensions','cameras','nodes','materials'):
        print(k, json.dumps(j.get(k)))
