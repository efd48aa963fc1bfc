#!/usr/bin/env python3
"""Writes scenes/data/uv-sphere.ply: the unit uv sphere (poles on z, 32 x 16 segments, with
per-vertex normals and uv) that scenes/displacement.pbrt and scenes/vturb.pbrt read.

Usage: python3 tools/make_uv_sphere.py > scenes/data/uv-sphere.ply
"""
import math

NU, NV = 32, 16


def vertex_index(i, j):
    """Index of vertex (i, j): ring j (theta = pi j / NV), column i (phi = 2 pi i / NU)."""
    return j * (NU + 1) + i


def main():
    verts = []
    for j in range(NV + 1):
        theta = math.pi * j / NV
        for i in range(NU + 1):  # the seam is duplicated (i = 0 and i = NU)
            phi = 2.0 * math.pi * i / NU
            p = (math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta))
            if j in (0, NV):  # the pole rows are kept, exactly on the axis
                p = (0.0, 0.0, 1.0 if j == 0 else -1.0)
            p = tuple(0.0 if abs(x) < 1e-9 else x for x in p)  # exact zeros on the axes
            verts.append(p + p + (i / NU, j / NV))
    faces = []
    for j in range(NV):
        for i in range(NU):
            a, b = vertex_index(i, j), vertex_index(i + 1, j)
            c, d = vertex_index(i, j + 1), vertex_index(i + 1, j + 1)
            if j == 0:
                faces.append((b, c, d))  # the top cap: one triangle per segment
            elif j == NV - 1:
                faces.append((a, c, b))  # the bottom cap
            else:
                faces.append((a, c, b))
                faces.append((b, c, d))
    print("ply\nformat ascii 1.0")
    print("comment basalt scenes/displacement.pbrt: unit sphere, poles on z, 32 x 16 segments;")
    print("comment vertex (i, j): theta = pi j / 16, phi = 2 pi i / 32, p = n = (sin theta cos phi,")
    print("comment sin theta sin phi, cos theta), uv = (i / 32, j / 16); pole rows are kept, seam duplicated")
    print(f"element vertex {len(verts)}")
    for name in ("x", "y", "z", "nx", "ny", "nz", "u", "v"):
        print(f"property float {name}")
    print(f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header")
    for v in verts:
        print(" ".join(f"{x:g}" for x in v))
    for f in faces:
        print("3 %d %d %d" % f)


if __name__ == "__main__":
    main()
