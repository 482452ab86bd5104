"""Import a measured run and save it as one netCDF file, one group per device stream.

Usage: python import_run_to_netcdf.py [SCENE] [OUT.nc]
(default: the first sample run shipped with rigval, written to run.nc)

The scene's channel map says which file holds which channel; each stream keeps its own device
clock, sampling rate, gaps and provenance (file, sha256) in its attributes.
"""

import sys
from pathlib import Path

import xarray as xr

from rigval.sample_data import shipped_runs
from rigval.validation.read_plan import read_streams
from rigval.validation.scene import load_scene


def main(scene_path: Path, out: Path) -> None:
    scene = load_scene(scene_path)
    streams = read_streams(scene)
    for name, stream in streams.items():
        print(f"{name}: {stream.attrs['device']}, {stream.sizes['time']} samples at "
              f"{stream.attrs['fs_nominal']:.1f} Hz, {stream.attrs['gap_count']} gaps, "
              f"channels {', '.join(v for v in stream.data_vars if v not in ('valid', 'segment'))}")
    tree = xr.DataTree.from_dict({f"/raw/{name}": ds for name, ds in streams.items()})
    tree.attrs.update(title=scene.title, scene_toml=scene.text)
    tree.to_netcdf(out, engine="netcdf4")
    print(f"wrote {out}")


if __name__ == "__main__":
    scene_arg = Path(sys.argv[1]) if len(sys.argv) > 1 else shipped_runs()[0]
    main(scene_arg, Path(sys.argv[2]) if len(sys.argv) > 2 else Path("run.nc"))
