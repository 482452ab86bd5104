"""Compare one measured channel with the model and plot it.

Usage: python compare_one_channel.py [SCENE] [COMPARISON] [OUT.png]
(default: the first sample run shipped with rigval, comparison acc1, written to acc1.png)

Runs the scene's validation (read, convert, align, angle domain, model, metrics), prints the
agreement scores of one comparison next to the cycle-to-cycle baseline, and saves its overlay.
"""

import sys
from pathlib import Path

from rigval.sample_data import shipped_runs
from rigval.validation.pipeline import run_scene
from rigval.validation.report.plots import plot_comparison


def main(scene_path: Path, name: str, out: Path) -> None:
    result = run_scene(scene_path)
    comparison = next(c for c in result.comparisons if c.name == name)
    print(f"{name}: {comparison.spec.measured} against {comparison.spec.model} "
          f"({comparison.cycles.shape[0]} revolutions)")
    for score in ("iso18571_periodic.rating", "sprague_geers.comprehensive", "nrmse",
                  "circular_lag.lag_deg"):
        print(f"  {score:30s} model {comparison.scores[score]:8.4f}   "
              f"median cycle {comparison.baseline['median'][score]:8.4f}")
    plot_comparison(comparison).savefig(out, dpi=120)
    print(f"wrote {out}")


if __name__ == "__main__":
    args = sys.argv[1:]
    main(Path(args[0]) if args else shipped_runs()[0], args[1] if len(args) > 1 else "acc1",
         Path(args[2]) if len(args) > 2 else Path("acc1.png"))
