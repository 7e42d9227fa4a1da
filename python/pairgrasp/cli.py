"""The `pairgrasp` command line.

Every failure prints one line `pairgrasp: error: ...` on stderr and exits with a non-zero status.
"""
from __future__ import annotations

import argparse
import sys

import numpy as np


class _Parser(argparse.ArgumentParser):
    """argparse that reports a bad command line in one line (exit status 2)."""

    def error(self, message: str):  # noqa: D102
        self.exit(2, f"pairgrasp: error: {message} (see: {self.prog} --help)\n")


def _fmt_vec(v) -> str:
    return "(" + ", ".join(f"{x:.4g}" for x in np.asarray(v, float).ravel()) + ")"


def _cmd_info(args) -> int:
    import pairgrasp as pg

    lines = [f"pairgrasp {pg.__version__}"]
    if args.hand:
        hand = pg.load_hand(args.hand)
        lines.append(f"hand {hand.name}: {len(hand.dof_names)} DOF, wrist link {hand.wrist_link}, "
                      f"approach {_fmt_vec(hand.approach)}")
        for name, lo, hi, st in zip(hand.dof_names, hand.dof_lower, hand.dof_upper, hand.dof_step):
            lines.append(f"  dof {name:<12s} [{lo:.4g}, {hi:.4g}]  step {st:.4g}")
        mid = (np.asarray(hand.dof_lower) + np.asarray(hand.dof_upper)) / 2
        per_link = hand.constellation(mid, mode="per_link")
        area = hand.constellation(mid, mode="area", spacing=args.spacing)
        lines.append(f"  constellation at mid-range: {len(per_link.points)} per-link samples, "
                     f"{len(area.points)} area samples at {args.spacing:g} m")
    if args.target:
        mesh = pg.load_mesh(args.target, scale=args.scale)
        lo, hi = np.asarray(mesh.bounds)
        lines.append(f"target {args.target}: {len(mesh.vertices)} vertices, {len(mesh.faces)} faces, "
                     f"closed {'yes' if mesh.closed else 'no'}")
        lines.append(f"  extent {_fmt_vec(hi - lo)} m, area {mesh.area:.5g} m^2, "
                     f"volume {mesh.volume:.5g} m^3, centre of mass {_fmt_vec(mesh.center_of_mass)} m")
        if args.paint:
            free = np.asarray(pg.load_paint(args.paint, mesh), bool)
            lines.append(f"  paint {args.paint}: {int(free.sum())} of {len(free)} faces free "
                         f"({100.0 * free.mean():.1f}%)")
    elif args.paint:
        raise ValueError("--paint needs --target")
    print("\n".join(lines))
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="pairgrasp", description="Grasp planning by pairwise-feature alignment.")
    sub = p.add_subparsers(dest="command", parser_class=_Parser)
    sub.required = True
    info = sub.add_parser("info", help="load a hand and/or a target and print their summary")
    info.add_argument("--hand", help="hand spec (JSON)")
    info.add_argument("--target", help="target mesh (STL, OBJ, PLY, DAE)")
    info.add_argument("--paint", help="paint file marking the target's free faces")
    info.add_argument("--scale", type=float, default=1.0, help="scale applied to the target (0.001: mm to m)")
    info.add_argument("--spacing", type=float, default=0.01, help="area-sample spacing (m) for the summary")
    info.set_defaults(func=_cmd_info)
    return p


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command == "info" and not (args.hand or args.target):
        parser.error("info needs --hand and/or --target")
    try:
        return args.func(args)
    except (ValueError, RuntimeError, OSError) as e:
        msg = " ".join(str(e).split())
        print(f"pairgrasp: error: {msg}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("pairgrasp: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
