#!/usr/bin/env python3
"""Plot of `volcl bench mesh-codec` (bench/results/mesh_codec.json) for docs/mesh-compression.md: per mesh, the --bits
knob as position error against size (bits per tet) and against encode/decode time, with gzip -9 and xz -9 of
the .vtu as lossless references. Usage: plot_mesh_codec.py [results.json] [image.png]"""
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

src = Path(sys.argv[1] if len(sys.argv) > 1 else "bench/results/mesh_codec.json")
out = Path(sys.argv[2] if len(sys.argv) > 2 else "docs/images/mesh_codec.png")
data = json.loads(src.read_text())

fig, (size_ax, time_ax) = plt.subplots(1, 2, figsize=(11, 4.2))
colours = ["tab:blue", "tab:orange", "tab:green", "tab:red"]
for colour, peer in zip(colours, data["peers"]):
    rows = [r for r in data["rows"] if r["mesh"] == peer["mesh"] and r["config"] != "lossless"]
    bits = [r["bits_per_tet"] for r in rows]
    err = [r["max_position_error_rel_diagonal"] for r in rows]
    size_ax.loglog(bits, err, "o-", color=colour, label=peer["mesh"] + " .vcm")
    for r in rows:
        size_ax.annotate(r["config"].split()[0], (r["bits_per_tet"], r["max_position_error_rel_diagonal"]),
                         textcoords="offset points", xytext=(4, 3), fontsize=7, color=colour)
    lossless = [r for r in data["rows"] if r["mesh"] == peer["mesh"] and r["config"] == "lossless"]
    for value, style, name in ((8 * peer["gzip9_bytes"] / peer["tets"], ":", "gzip -9 .vtu"),
                               (8 * peer["xz9_bytes"] / peer["tets"], "--", "xz -9 .vtu")) + tuple(
            (r["bits_per_tet"], "-.", ".vcm lossless") for r in lossless):
        size_ax.axvline(value, color=colour, linestyle=style, linewidth=0.8)
        size_ax.annotate(name, (value, size_ax.get_ylim()[0] if False else min(err)), rotation=90, fontsize=6,
                         color=colour, xytext=(2, 0), textcoords="offset points")
    time_ax.semilogy([r["encode_ms"] for r in rows], err, "o-", color=colour, label=peer["mesh"] + " encode")
    time_ax.semilogy([r["decode_ms"] for r in rows], err, "s--", color=colour, label=peer["mesh"] + " decode")
size_ax.set_xlabel("bits per tet (whole file)")
size_ax.set_ylabel("max position error / box diagonal")
size_ax.set_title("--bits: error against size (vertical lines: lossless)")
size_ax.legend(fontsize=7)
time_ax.set_xlabel("milliseconds (median of interleaved runs, load %s)" % data["load_average"])
time_ax.set_ylabel("max position error / box diagonal")
time_ax.set_title("--bits: error against time")
time_ax.legend(fontsize=7)
fig.tight_layout()
out.parent.mkdir(parents=True, exist_ok=True)
fig.savefig(out, dpi=110)
print("wrote", out)
