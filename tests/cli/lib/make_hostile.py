"""Files whose headers claim hostile sizes, for tests/cli/faults.sh (standard library only).

    make_hostile.py safetensors-data OUT   a tensor of 10^12 bytes (shape 500000 x 500000
                                           float32), no data
    make_hostile.py safetensors-hlen OUT   a header length of 10^12 bytes in a 64-byte file
    make_hostile.py npy OUT                a float32 .npy of shape (100000, 100000), no data
    make_hostile.py graph OUT N            a material fed by a chain of N Math nodes,
                                           in compact JSON (about 130 bytes a node)
"""
import json
import struct
import sys


def safetensors_data(path):
    header = json.dumps({"w": {"dtype": "F32", "shape": [500000, 500000],
                               "data_offsets": [0, 10**12]}}).encode()
    with open(path, "wb") as f:
        f.write(struct.pack("<Q", len(header)) + header + b"\0" * 16)


def safetensors_hlen(path):
    with open(path, "wb") as f:
        f.write(struct.pack("<Q", 10**12) + b"{" + b" " * 55)


def npy(path):
    header = "{'descr': '<f4', 'fortran_order': False, 'shape': (100000, 100000), }"
    header += " " * (127 - 10 - len(header)) + "\n"
    with open(path, "wb") as f:
        f.write(b"\x93NUMPY\x01\x00" + struct.pack("<H", len(header)) + header.encode())
        f.write(b"\0" * 64)


def graph(path, n):
    # Written as it goes: a million nodes would be a gigabyte as Python objects.
    m = lambda i: '{"name":"M%d","type":"ShaderNodeMath"}' % i
    link = '{"from_node":"%s","from_socket":"%s","to_node":"%s","to_socket":"%s"}'
    with open(path, "w") as f:
        f.write('{"format":"imsynth-graph/1","nodes":[{"name":"O","type":"ShaderNodeOutputMaterial"},'
                '{"name":"P","type":"ShaderNodeBsdfPrincipled"}')
        for i in range(n):
            f.write("," + m(i))
        f.write('],"links":[' + link % ("P", "BSDF", "O", "Surface"))
        for i in range(1, n):
            f.write("," + link % ("M%d" % (i - 1), "Value", "M%d" % i, "Value"))
        f.write("," + link % ("M%d" % (n - 1), "Value", "P", "Roughness") + "]}")


if __name__ == "__main__":
    kind, out = sys.argv[1], sys.argv[2]
    if kind == "graph":
        graph(out, int(sys.argv[3]))
    else:
        {"safetensors-data": safetensors_data, "safetensors-hlen": safetensors_hlen,
         "npy": npy}[kind](out)
