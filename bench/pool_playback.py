"""Pools the decode timings of several `volcl bench series` runs of the same series into one file: per
series, rate and mode, the median over every run's samples (the runs interleave intra-only and MC decodes,
so pooled samples keep that pairing's fairness), in the bench's row format for plot_playback.py.

Usage: pool_playback.py out.json run1.json run2.json ...
"""
import json
import statistics
import sys


def main():
    runs = [json.load(open(p)) for p in sys.argv[2:]]
    pooled = {}
    for run in runs:
        for r in run["rows"]:
            key = (r["series"], r["rate"], r["mode"])
            p = pooled.setdefault(key, dict(r, **{k: [] for k in ("playback_ms_runs", "frame_decode_ms_runs",
                                                                 "playback_cpu_ms_runs", "frame_decode_cpu_ms_runs")},
                                            load=[]))
            for k in ("playback_ms_runs", "frame_decode_ms_runs", "playback_cpu_ms_runs", "frame_decode_cpu_ms_runs"):
                p[k] += r.get(k, [])
            p["load"] += [r["load_before"], r["load_after"]]
    rows = []
    for (series, rate, mode), p in pooled.items():
        frames = p["frames"]
        p["playback_fps"] = 1e3 * frames / statistics.median(p["playback_ms_runs"])
        p["frame_decode_ms"] = statistics.median(p["frame_decode_ms_runs"])
        p["frame_decode_cpu_ms"] = statistics.median(p["frame_decode_cpu_ms_runs"])
        p["playback_cpu_ms_per_frame"] = statistics.median(p["playback_cpu_ms_runs"]) / frames
        rows.append(p)
    for p in rows:
        intra = pooled[(p["series"], p["rate"], "intra")]
        p["frame_decode_over_intra"] = p["frame_decode_ms"] / intra["frame_decode_ms"]
        p["frame_decode_cpu_over_intra"] = p["frame_decode_cpu_ms"] / intra["frame_decode_cpu_ms"]
        print(f'{p["series"]} {p["rate"]} {p["mode"]}: frame {p["frame_decode_ms"]:.1f} ms '
              f'(x{p["frame_decode_over_intra"]:.2f}), CPU {p["frame_decode_cpu_ms"]:.1f} ms '
              f'(x{p["frame_decode_cpu_over_intra"]:.2f}); playback {p["playback_fps"]:.1f} fps, '
              f'CPU {p["playback_cpu_ms_per_frame"]:.1f} ms/frame; samples {len(p["frame_decode_ms_runs"])}; '
              f'load {min(p["load"]):.1f}-{max(p["load"]):.1f}')
    json.dump({"device": runs[0]["device"], "runs": len(runs), "rows": rows}, open(sys.argv[1], "w"), indent=1)


if __name__ == "__main__":
    main()
