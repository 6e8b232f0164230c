"""Record an episode as a GIF (or MP4), headless: no display needed.

    python examples/record_gif.py [--map roundabout] [--agent nao] [--seed 0]
                                  [--seconds 20] [--fps 10] [--out roundabout.gif]

The left of each frame is the world (robots coloured by agent, their goals,
trails, walls, traffic); the right is the first robot's acceleration space
(its neighbours' NAOs, the a_max circle, the desired and the chosen
acceleration). The same from the command line:

    nao-arena run roundabout --render gif --out roundabout.gif
"""

from __future__ import annotations

import argparse
import math

from nao_arena.arena import Arena, ArenaOptions
from nao_arena.maps import load_map, parse_overrides
from nao_arena.render import record_episode


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="Record one episode.")
    parser.add_argument("--map", default="roundabout", help="shipped map name or map file")
    parser.add_argument("--agent", default=None, help="agent of the robots (default: the map's)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--set", nargs="*", default=[], metavar="KEY=VALUE", help="map parameters, e.g. n=4"
    )
    parser.add_argument(
        "--seconds",
        type=float,
        default=20.0,
        help="simulated seconds to record (at most the episode)",
    )
    parser.add_argument("--fps", type=float, default=10.0, help="frames per simulated second")
    parser.add_argument("--out", default="roundabout.gif", help="a .gif or .mp4 file")
    args = parser.parse_args(argv)

    spec = load_map(args.map, **parse_overrides(args.set))
    arena = Arena(spec, ArenaOptions(agent=args.agent))
    arena.reset(args.seed)
    steps = math.ceil(args.seconds / spec.physics.dt)
    path = record_episode(arena, args.out, fps=args.fps, max_steps=steps)
    print(f"wrote {path} ({arena.state.time:.1f} s of {spec.name})")


if __name__ == "__main__":
    main()
