"""Writes the hand-made test meshes of test/data/ and the bad files of test/data/bad/.

usage: /usr/bin/python3 make_test_data.py <test/data directory>

The base is a unit cube split into 6 tets around its diagonal, plus one vertex no tet uses and
one triangle (which the readers skip), written in every format; each bad file is one of these
with a single defect, so that the test can check that the error names that defect.
"""
import math
import os
import random
import struct
import sys

CUBE_POINTS = [(float(i & 1), float((i >> 1) & 1), float((i >> 2) & 1)) for i in range(8)]
CUBE_POINTS.append((5.0, 5.0, 5.0))  # used by no tet
CUBE_TETS = [[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]]
TRIANGLE = [0, 1, 3]


def signed_volume(points, tet):
    a, b, c, d = (points[i] for i in tet)
    u = [b[k] - a[k] for k in range(3)]
    v = [c[k] - a[k] for k in range(3)]
    w = [d[k] - a[k] for k in range(3)]
    return (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) +
            u[2] * (v[0] * w[1] - v[1] * w[0])) / 6.0


def positive(tets):
    return [t if signed_volume(CUBE_POINTS, t) > 0 else [t[0], t[1], t[3], t[2]] for t in tets]


TETS = positive(CUBE_TETS)
# The same tets with every other one negatively oriented.
FLIPPED_TETS = [[t[1], t[0], t[2], t[3]] if i % 2 else t for i, t in enumerate(TETS)]
# The bottom face as a tet: zero volume.
FLAT_TET = [0, 1, 3, 2]


def fmt(x):
    return repr(float(x)) if math.isfinite(x) else str(x)


# ---------------------------------------------------------------------------------------------
# Writers of the base formats.

def msh22_ascii(points=CUBE_POINTS, tets=TETS):
    lines = ["$MeshFormat", "2.2 0 8", "$EndMeshFormat", "$Nodes", str(len(points))]
    lines += [f"{i + 1} {fmt(x)} {fmt(y)} {fmt(z)}" for i, (x, y, z) in enumerate(points)]
    lines += ["$EndNodes", "$Elements", str(len(tets) + 1)]
    lines.append("1 2 2 0 1 " + " ".join(str(i + 1) for i in TRIANGLE))
    lines += [f"{e + 2} 4 2 0 1 " + " ".join(str(i + 1) for i in t) for e, t in enumerate(tets)]
    lines.append("$EndElements")
    return ("\n".join(lines) + "\n").encode()


def msh22_binary(points=CUBE_POINTS, tets=TETS, block_size=None):
    out = b"$MeshFormat\n2.2 1 8\n" + struct.pack("<i", 1) + b"\n$EndMeshFormat\n"
    out += b"$Nodes\n%d\n" % len(points)
    for i, p in enumerate(points):
        out += struct.pack("<i3d", i + 1, *p)
    out += b"\n$EndNodes\n$Elements\n%d\n" % (len(tets) + 1)
    out += struct.pack("<3i", 2, 1, 2) + struct.pack("<6i", 1, 0, 1, *[i + 1 for i in TRIANGLE])
    out += struct.pack("<3i", 4, len(tets) if block_size is None else block_size, 2)
    for e, t in enumerate(tets):
        out += struct.pack("<7i", e + 2, 0, 1, *[i + 1 for i in t])
    out += b"\n$EndElements\n"
    return out


def msh41_ascii(points=CUBE_POINTS, tets=TETS, bounding="1", node_range=None):
    n = len(points)
    lines = ["$MeshFormat", "4.1 0 8", "$EndMeshFormat", "$Entities", "0 0 1 1",
             "1 0 0 0 1 1 1 0 0", f"1 0 0 0 1 1 1 0 1 {bounding}", "$EndEntities", "$Nodes",
             f"1 {n} {node_range or f'1 {n}'}", f"3 1 0 {n}"]
    lines += [str(i + 1) for i in range(n)]
    lines += [f"{fmt(x)} {fmt(y)} {fmt(z)}" for (x, y, z) in points]
    lines += ["$EndNodes", "$Elements", f"2 {len(tets) + 1} 1 {len(tets) + 1}", "2 1 2 1",
              "1 " + " ".join(str(i + 1) for i in TRIANGLE), f"3 1 4 {len(tets)}"]
    lines += [f"{e + 2} " + " ".join(str(i + 1) for i in t) for e, t in enumerate(tets)]
    lines.append("$EndElements")
    return ("\n".join(lines) + "\n").encode()


def msh41_binary(points=CUBE_POINTS, tets=TETS, num_nodes=None):
    n = len(points)
    out = b"$MeshFormat\n4.1 1 8\n" + struct.pack("<i", 1) + b"\n$EndMeshFormat\n"
    out += b"$Entities\n" + struct.pack("<4Q", 0, 0, 1, 1)
    out += struct.pack("<i6dQQ", 1, 0, 0, 0, 1, 1, 1, 0, 0)
    out += struct.pack("<i6dQQi", 1, 0, 0, 0, 1, 1, 1, 0, 1, 1)
    out += b"\n$EndEntities\n$Nodes\n"
    out += struct.pack("<4Q", 1, n if num_nodes is None else num_nodes, 1, n)
    out += struct.pack("<3iQ", 3, 1, 0, n)
    out += struct.pack(f"<{n}Q", *range(1, n + 1))
    for p in points:
        out += struct.pack("<3d", *p)
    out += b"\n$EndNodes\n$Elements\n"
    out += struct.pack("<4Q", 2, len(tets) + 1, 1, len(tets) + 1)
    out += struct.pack("<3iQ", 2, 1, 2, 1) + struct.pack("<4Q", 1, *[i + 1 for i in TRIANGLE])
    out += struct.pack("<3iQ", 3, 1, 4, len(tets))
    for e, t in enumerate(tets):
        out += struct.pack("<5Q", e + 2, *[i + 1 for i in t])
    out += b"\n$EndElements\n"
    return out


def tetgen_node(points=CUBE_POINTS, first=1, attributes=0, markers=0):
    lines = ["# cube corners and one unused point", f"{len(points)} 3 {attributes} {markers}"]
    for i, (x, y, z) in enumerate(points):
        extra = [f"{0.5 * i}"] * attributes + ["1"] * markers
        lines.append(" ".join([str(i + first), fmt(x), fmt(y), fmt(z)] + extra) + "  # point")
    return ("\n".join(lines) + "\n").encode()


def tetgen_ele(tets=TETS, first=1, attributes=0):
    lines = [f"{len(tets)} 4 {attributes}", ""]
    for e, t in enumerate(tets):
        lines.append(" ".join([str(e + first)] + [str(i + first) for i in t] + ["7"] * attributes))
    lines.append("# end")
    return ("\n".join(lines) + "\n").encode()


def vtk_ascii(points=CUBE_POINTS, tets=TETS, cell_size=None, dataset="UNSTRUCTURED_GRID"):
    cells = [TRIANGLE] + tets
    size = sum(len(c) + 1 for c in cells)
    lines = ["# vtk DataFile Version 2.0", "cube", "ASCII", f"DATASET {dataset}",
             f"POINTS {len(points)} double"]
    lines += [f"{fmt(x)} {fmt(y)} {fmt(z)}" for (x, y, z) in points]
    lines.append(f"CELLS {len(cells)} {size if cell_size is None else cell_size}")
    lines += [f"{len(c)} " + " ".join(map(str, c)) for c in cells]
    lines.append(f"CELL_TYPES {len(cells)}")
    lines += ["5"] + ["10"] * len(tets)
    return ("\n".join(lines) + "\n").encode()


def vtk_binary(points=CUBE_POINTS, tets=TETS, first_count=None):
    cells = [TRIANGLE] + tets
    size = sum(len(c) + 1 for c in cells)
    out = b"# vtk DataFile Version 3.0\ncube\nBINARY\nDATASET UNSTRUCTURED_GRID\n"
    out += b"POINTS %d float\n" % len(points)
    for p in points:
        out += struct.pack(">3f", *p)
    out += b"\nCELLS %d %d\n" % (len(cells), size)
    for i, c in enumerate(cells):
        count = len(c) if (first_count is None or i != 1) else first_count
        out += struct.pack(f">{len(c) + 1}i", count, *c)
    out += b"\nCELL_TYPES %d\n" % len(cells)
    out += struct.pack(f">{len(cells)}i", 5, *([10] * len(tets)))
    out += b"\n"
    return out


CUBE_FACETS = [  # outward
    [0, 2, 3], [0, 3, 1], [4, 5, 7], [4, 7, 6], [0, 1, 5], [0, 5, 4],
    [2, 6, 7], [2, 7, 3], [0, 4, 6], [0, 6, 2], [1, 3, 7], [1, 7, 5]]


def stl_ascii(facets=CUBE_FACETS, points=CUBE_POINTS):
    lines = ["solid cube"]
    for f in facets:
        lines += ["  facet normal 0 0 0", "    outer loop"]
        lines += ["      vertex " + " ".join(fmt(x) for x in points[i]) for i in f]
        lines += ["    endloop", "  endfacet"]
    lines.append("endsolid cube")
    return ("\n".join(lines) + "\n").encode()


def stl_binary(facets=CUBE_FACETS, points=CUBE_POINTS):
    # The header starts with "solid" on purpose: binary files written that way exist.
    out = b"solid cube, binary".ljust(80, b" ") + struct.pack("<I", len(facets))
    for f in facets:
        out += struct.pack("<3f", 0, 0, 0)
        for i in f:
            out += struct.pack("<3f", *points[i])
        out += b"\0\0"
    return out


# ---------------------------------------------------------------------------------------------

def replace_once(data, old, new):
    assert data.count(old) >= 1, (old, data[:200])
    return data.replace(old, new, 1)


def garbage(size, seed):
    rng = random.Random(seed)
    return bytes(rng.randrange(256) for _ in range(size))


def main(data_dir):
    bad_dir = os.path.join(data_dir, "bad")
    os.makedirs(bad_dir, exist_ok=True)

    def put(directory, name, content):
        with open(os.path.join(directory, name), "wb") as f:
            f.write(content)

    nan_points = list(CUBE_POINTS)
    nan_points[3] = (1.0, float("nan"), 0.0)
    inf_points = list(CUBE_POINTS)
    inf_points[5] = (float("inf"), 0.0, 1.0)
    out_of_range = [list(t) for t in TETS]
    out_of_range[2][3] = 98
    flat = [list(t) for t in TETS]
    flat[4] = FLAT_TET

    # Good hand-made files.
    put(data_dir, "cube_v22.msh", msh22_ascii())
    put(data_dir, "cube_v22_binary.msh", msh22_binary())
    put(data_dir, "cube_v41.msh", msh41_ascii())
    put(data_dir, "cube_v41_binary.msh", msh41_binary())
    put(data_dir, "cube.node", tetgen_node())
    put(data_dir, "cube.ele", tetgen_ele())
    put(data_dir, "cube_ascii.vtk", vtk_ascii())
    put(data_dir, "cube_binary.vtk", vtk_binary())
    put(data_dir, "cube.stl", stl_ascii())
    put(data_dir, "cube_binary.stl", stl_binary())
    # Negatively oriented tets, 0-based TetGen with attributes and boundary markers.
    put(data_dir, "cube_flipped.node", tetgen_node(first=0, attributes=2, markers=1))
    put(data_dir, "cube_flipped.ele", tetgen_ele(FLIPPED_TETS, first=0, attributes=1))
    put(data_dir, "cube_flipped.vtk", vtk_ascii(tets=FLIPPED_TETS))

    # Gmsh 2.2 ASCII.
    good = msh22_ascii()
    put(bad_dir, "msh22_empty.msh", b"")
    put(bad_dir, "msh22_garbage.msh", garbage(3000, 1))
    put(bad_dir, "msh22_malformed.msh", replace_once(good, b"\n4 1.0 1.0 0.0\n", b"\n4 1.0 one 0.0\n"))
    put(bad_dir, "msh22_truncated.msh", good[:good.index(b"$Elements") + 40])
    put(bad_dir, "msh22_nonfinite.msh", msh22_ascii(points=nan_points))
    put(bad_dir, "msh22_out_of_range.msh", msh22_ascii(tets=out_of_range))
    put(bad_dir, "msh22_zero_volume.msh", msh22_ascii(tets=flat))
    put(bad_dir, "msh22_count_mismatch.msh", replace_once(good, b"$Nodes\n9\n", b"$Nodes\n10\n"))
    line = b"\n3 4 2 0 1"
    start = good.index(line) + 1
    element = good[start:good.index(b"\n", start) + 1]
    put(bad_dir, "msh22_duplicated_line.msh", good.replace(element, element + element, 1))
    put(bad_dir, "msh22_no_header.msh", good[good.index(b"$Nodes"):])
    put(bad_dir, "msh_version40.msh", replace_once(good, b"2.2 0 8", b"4 0 8"))
    put(bad_dir, "msh22_unclosed.msh", good.replace(b"$EndNodes\n", b""))
    # Gmsh 2.2 binary.
    good = msh22_binary()
    put(bad_dir, "msh22_binary_truncated.msh", good[:len(good) - 40])
    put(bad_dir, "msh22_binary_block_size.msh", msh22_binary(block_size=1000000))
    put(bad_dir, "msh22_binary_nonfinite.msh", msh22_binary(points=inf_points))
    # Gmsh 4.1 ASCII.
    good = msh41_ascii()
    put(bad_dir, "msh41_empty.msh", b"")
    put(bad_dir, "msh41_garbage.msh", b"$MeshFormat\n4.1 0 8\n$EndMeshFormat\n" +
        garbage(2000, 2))
    put(bad_dir, "msh41_malformed.msh", replace_once(good, b"\n1.0 1.0 0.0\n", b"\n1.0 1.0 0.0 x\n"))
    put(bad_dir, "msh41_truncated.msh", good[:good.index(b"$Elements") + 30])
    put(bad_dir, "msh41_nonfinite.msh", msh41_ascii(points=nan_points))
    put(bad_dir, "msh41_out_of_range.msh", msh41_ascii(tets=out_of_range))
    put(bad_dir, "msh41_zero_volume.msh", msh41_ascii(tets=flat))
    put(bad_dir, "msh41_tag_range.msh", msh41_ascii(node_range="1 12"))
    put(bad_dir, "msh41_bounding.msh", msh41_ascii(bounding="7"))
    # Gmsh 4.1 binary.
    good = msh41_binary()
    put(bad_dir, "msh41_binary_truncated.msh", good[:good.index(b"$Elements") + 60])
    put(bad_dir, "msh41_binary_huge_count.msh", msh41_binary(num_nodes=2**62))
    put(bad_dir, "msh41_binary_nonfinite.msh", msh41_binary(points=nan_points))

    # TetGen.
    node, ele = tetgen_node(), tetgen_ele()
    for name, n, e in [
            ("tetgen_empty", b"", ele),
            ("tetgen_garbage", garbage(1500, 3), ele),
            ("tetgen_malformed", node, replace_once(ele, b"\n3 ", b"\n3 x")),
            ("tetgen_truncated", node, ele[:ele.index(b"\n4 ")]),
            ("tetgen_nonfinite", tetgen_node(points=inf_points), ele),
            ("tetgen_out_of_range", node, tetgen_ele(out_of_range)),
            ("tetgen_zero_volume", node, tetgen_ele(flat)),
            ("tetgen_extra_line", node + node.splitlines(True)[-1], ele),
            ("tetgen_bad_numbering", replace_once(node, b"\n4 1.0", b"\n5 1.0"), ele)]:
        put(bad_dir, name + ".node", n)
        put(bad_dir, name + ".ele", e)
    put(bad_dir, "tetgen_missing_ele.node", node)

    # VTK ASCII.
    good = vtk_ascii()
    put(bad_dir, "vtk_empty.vtk", b"")
    put(bad_dir, "vtk_garbage.vtk", garbage(2500, 4))
    put(bad_dir, "vtk_malformed.vtk", replace_once(good, b"\n1.0 1.0 0.0\n", b"\n1.0 1.0 zero\n"))
    put(bad_dir, "vtk_truncated.vtk", good[:good.index(b"CELL_TYPES") + 16])
    put(bad_dir, "vtk_nonfinite.vtk", vtk_ascii(points=nan_points))
    put(bad_dir, "vtk_out_of_range.vtk", vtk_ascii(tets=out_of_range))
    put(bad_dir, "vtk_zero_volume.vtk", vtk_ascii(tets=flat))
    put(bad_dir, "vtk_cells_size.vtk", vtk_ascii(cell_size=40))
    put(bad_dir, "vtk_polydata.vtk", vtk_ascii(dataset="POLYDATA"))
    # VTK binary.
    good = vtk_binary()
    put(bad_dir, "vtk_binary_truncated.vtk", good[:good.index(b"CELLS") + 60])
    put(bad_dir, "vtk_binary_nonfinite.vtk", vtk_binary(points=inf_points))
    put(bad_dir, "vtk_binary_out_of_range.vtk", vtk_binary(tets=out_of_range))
    put(bad_dir, "vtk_binary_zero_volume.vtk", vtk_binary(tets=flat))
    put(bad_dir, "vtk_binary_cell_count.vtk", vtk_binary(first_count=100000))
    put(bad_dir, "vtk_binary_garbage.vtk", good[:good.index(b"POINTS")] + garbage(2000, 5))

    # STL.
    good = stl_ascii()
    put(bad_dir, "stl_empty.stl", b"")
    put(bad_dir, "stl_garbage.stl", garbage(1000, 6))
    put(bad_dir, "stl_malformed.stl", replace_once(good, b"    endloop\n", b""))
    put(bad_dir, "stl_truncated.stl", stl_binary()[:300])
    put(bad_dir, "stl_ascii_truncated.stl", good[:good.index(b"endfacet") + 9])
    put(bad_dir, "stl_nonfinite.stl", stl_ascii(points=nan_points))
    put(bad_dir, "stl_open.stl", stl_ascii(facets=CUBE_FACETS[:-1]))
    put(bad_dir, "stl_degenerate.stl", stl_ascii(facets=CUBE_FACETS + [[0, 0, 7]]))

    put(bad_dir, "mesh.xyz", b"0 0 0\n1 0 0\n")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
