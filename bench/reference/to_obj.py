#!/usr/bin/env python3
"""Usage: to_obj.py IN.(obj|off|ply) OUT.obj

Writes a plain OBJ (v and f lines only, vertex and face order kept) for the reference drivers
(README.md), which read nothing else. Coordinates are written exactly (repr of the double the
file holds): with 9 digits a float32 PLY round-trips for a float reader but not for a double
reader, and horse.ply's distances then move by 2e-9. Triangles only; PLY binary little-endian or
ascii, with one vertex element (x, y, z among scalar properties) and one face list element.
"""
import os
import struct
import sys

# OBJ and OFF: the readers of scripts/subdivide_mesh.py.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'scripts'))
from subdivide_mesh import read_obj, read_off  # noqa: E402

PLY_TYPES = {'char': 'b', 'int8': 'b', 'uchar': 'B', 'uint8': 'B', 'short': 'h', 'int16': 'h',
             'ushort': 'H', 'uint16': 'H', 'int': 'i', 'int32': 'i', 'uint': 'I', 'uint32': 'I',
             'float': 'f', 'float32': 'f', 'double': 'd', 'float64': 'd'}


def read_ply(path):
    data = open(path, 'rb').read()
    end = data.index(b'end_header') + len(b'end_header')
    end = data.index(b'\n', end) + 1
    header = data[:end].decode('ascii').split('\n')
    binary = 'binary_little_endian' in header[1]
    assert binary or 'ascii' in header[1], 'PLY must be ascii or binary little-endian'
    elements = []
    for line in header:
        tokens = line.split()
        if tokens and tokens[0] == 'element':
            elements.append((tokens[1], int(tokens[2]), []))
        elif tokens and tokens[0] == 'property':
            elements[-1][2].append(tokens[1:])
    words = data[end:].split() if not binary else None
    at = end if binary else 0
    vertices, faces = [], []
    for name, count, props in elements:
        for _ in range(count):
            values = []
            for prop in props:
                if prop[0] == 'list':
                    if binary:
                        (n,) = struct.unpack_from('<' + PLY_TYPES[prop[1]], data, at)
                        at += struct.calcsize(PLY_TYPES[prop[1]])
                        item = '<%d%s' % (n, PLY_TYPES[prop[2]])
                        values.append(struct.unpack_from(item, data, at))
                        at += struct.calcsize(item)
                    else:
                        n = int(words[at])
                        values.append(tuple(int(w) for w in words[at + 1:at + 1 + n]))
                        at += 1 + n
                elif binary:
                    (value,) = struct.unpack_from('<' + PLY_TYPES[prop[0]], data, at)
                    at += struct.calcsize(PLY_TYPES[prop[0]])
                    values.append(value)
                else:
                    values.append(float(words[at]))
                    at += 1
            names = [p[-1] for p in props]
            if name == 'vertex':
                vertices.append(tuple(values[names.index(c)] for c in 'xyz'))
            elif name == 'face':
                faces.append(tuple(values[0]))
    return vertices, faces


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    path = sys.argv[1]
    reader = {'obj': read_obj, 'off': read_off, 'ply': read_ply}[path.rsplit('.', 1)[-1].lower()]
    vertices, faces = reader(path)
    if any(len(f) != 3 for f in faces):
        sys.exit('only triangles are supported')
    with open(sys.argv[2], 'w') as out:
        for v in vertices:
            out.write('v %r %r %r\n' % tuple(float(c) for c in v))
        for f in faces:
            out.write('f %d %d %d\n' % tuple(i + 1 for i in f))
    print('%s: %d vertices, %d faces' % (sys.argv[2], len(vertices), len(faces)))


if __name__ == '__main__':
    main()
