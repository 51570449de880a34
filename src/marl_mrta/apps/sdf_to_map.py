"""Digitise an SDF world (building-model export) into a map_server map (YAML + PGM).

    sdf_to_map maps/lab.sdf maps/lab.yaml --origin -0.5 -0.5 --size 8.0 6.0

Writes OUTPUT (.yaml) and the PGM beside it. Bad input: one line on stderr, exit status 1.
"""
import argparse
import sys
from pathlib import Path

from marl_mrta.model.occupancy_map import OCCUPIED, save_map
from marl_mrta.model.sdf_to_map import HeightBand, MapRequest, SdfError, sdf_to_occupancy_map


class _OneLineParser(argparse.ArgumentParser):
    def error(self, message):
        sys.exit(f"{self.prog}: {message}")


def main() -> int:
    parser = _OneLineParser(prog="sdf_to_map", description=__doc__.splitlines()[0])
    parser.add_argument("sdf", type=Path, help="input SDF file")
    parser.add_argument("output", type=Path, help="output map YAML; the PGM goes beside it")
    parser.add_argument("--resolution", type=float, default=0.05, help="cell size, m (0.05)")
    parser.add_argument("--z-min", type=float, default=0.05, help="bottom of the height band "
                        "whose obstacles are mapped, m (0.05)")
    parser.add_argument("--z-max", type=float, default=0.5, help="top of the band, m (0.5)")
    parser.add_argument("--margin", type=float, default=0.5, help="free border around the "
                        "obstacles when origin/size are not given, m (0.5)")
    parser.add_argument("--origin", type=float, nargs=2, metavar=("X", "Y"),
                        help="world position of the map's lower-left corner, m")
    parser.add_argument("--size", type=float, nargs=2, metavar=("WIDTH", "HEIGHT"),
                        help="map extent, m")
    args = parser.parse_args()
    if args.output.suffix != ".yaml":
        sys.exit(f"sdf_to_map: {args.output}: output must end in .yaml")

    request = MapRequest(resolution=args.resolution, band=HeightBand(args.z_min, args.z_max),
                         margin=args.margin, origin=args.origin and tuple(args.origin),
                         size=args.size and tuple(args.size))
    try:
        occupancy_map = sdf_to_occupancy_map(args.sdf, request)
        image = save_map(occupancy_map, args.output, comment=(
            f"Digitised from {args.sdf.name} by sdf_to_map: obstacles between "
            f"{args.z_min:.2f} and {args.z_max:.2f} m."))
    except SdfError as err:
        sys.exit(str(err))
    except OSError as err:
        sys.exit(f"{err.filename}: output: cannot write ({err.strerror})")
    origin = occupancy_map.origin
    print(f"{args.output} + {image.name}: {occupancy_map.width} x {occupancy_map.height} cells "
          f"of {occupancy_map.resolution:.3f} m, origin ({origin.x:.3f}, {origin.y:.3f}), "
          f"{int((occupancy_map.grid == OCCUPIED).sum())} occupied")
    return 0
