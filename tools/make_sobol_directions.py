#!/usr/bin/python3
"""Writes host/scene/sobol_directions.inc: Joe and Kuo's Sobol' direction numbers
(new-joe-kuo-6.21201) for dimensions 1..1023, read from the copy Debian's python3-scipy ships
(scipy/stats/_sobol_direction_numbers.npz, whose rows are Joe and Kuo's file in order).

Run with Debian's interpreter (it has python3-scipy): /usr/bin/python3 tools/make_sobol_directions.py
The output is data, checked in; the build does not need scipy.
"""
import pathlib

import numpy as np

DIMS = 1024  # SOBOL_DIMENSIONS in shaders/shared/layout.h
src = np.load("/usr/lib/python3/dist-packages/scipy/stats/_sobol_direction_numbers.npz")
poly, vinit = src["poly"], src["vinit"]
out = pathlib.Path(__file__).resolve().parent.parent / "host/scene/sobol_directions.inc"
lines = [
    "// Sobol' direction numbers of dimensions 1..1023 (dimension 0 is van der Corput): one row",
    "// per dimension, {s, a, {m_1, ..., m_s}} as in Joe and Kuo's file new-joe-kuo-6.21201 (S. Joe",
    "// and F. Y. Kuo, \"Constructing Sobol sequences with better two-dimensional projections\",",
    "// SIAM J. Sci. Comput. 30 (2008) 2635-2654; https://web.maths.unsw.edu.au/~fkuo/sobol/).",
    "// s: degree of the primitive polynomial; a: its inner coefficients, a_1 the highest bit;",
    "// m: the initial direction numbers. Written by tools/make_sobol_directions.py.",
    "//",
    "// Copyright (c) 2008, Frances Y. Kuo and Stephen Joe. All rights reserved. Redistribution",
    "// and use in source and binary forms, with or without modification, are permitted provided",
    "// that: redistributions of source code retain this copyright notice, this list of conditions",
    "// and the following disclaimer; redistributions in binary form reproduce them in the",
    "// documentation and/or other materials provided with the distribution; and neither the names",
    "// of the copyright holders nor the names of the University of New South Wales and the",
    "// University of Waikato and its contributors are used to endorse or promote products derived",
    "// from this software without specific prior written permission. THIS SOFTWARE IS PROVIDED BY",
    "// THE COPYRIGHT HOLDERS AND CONTRIBUTORS \"AS IS\" AND ANY EXPRESS OR IMPLIED WARRANTIES ARE",
    "// DISCLAIMED; IN NO EVENT SHALL THE COPYRIGHT HOLDERS OR CONTRIBUTORS BE LIABLE FOR ANY",
    "// DAMAGES ARISING IN ANY WAY OUT OF THE USE OF THIS SOFTWARE.",
]
for d in range(1, DIMS):
    p = int(poly[d])
    s = p.bit_length() - 1
    a = (p >> 1) & ((1 << (s - 1)) - 1)
    m = [int(v) for v in vinit[d][:s]]
    assert all(v % 2 == 1 and v < (1 << (k + 1)) for k, v in enumerate(m)), d
    lines.append("{%d, %d, {%s}}," % (s, a, ", ".join(map(str, m))))
out.write_text("\n".join(lines) + "\n")
print(f"wrote {out} ({DIMS - 1} dimensions)")
