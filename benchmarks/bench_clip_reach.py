"""Can a pull-out clip of the car ahead in a queue send the striker into the next car of the queue first at an angle?

Run by hand: `.venv/bin/python benchmarks/bench_clip_reach.py [--friction 0.8] [--striker 17,21,...] [--clipped 13,...]
[--third 1,1.1,...] [--ignore-clipped]`. Sweeps what a reproduce plan may
choose (`simulate.embedded.clipahead`, the plan of a clip followed by a contact with a car ahead of the clipped one in
its lane): the striker's and the clipped car's speeds, where the clip starts (the clipped car's place ahead, every
PLACE_STEP, giving every overlap of the two bodies the pull-out path meets), and the third car's speed (no slower
than the clipped car's, else its driver closes in on it and brakes) and start (any gap ahead of the clipped car).
The pull-out is the simulator's (`swerve.paths`, a lane change), the clip stepped as the simulator steps it
(`clipahead.clip_pairs`), the meeting as `clipahead.place_ahead` finds it. Prints how many clips there are, how many
of them meet the third car first with the written class at some start of it, in how many the clipped car leaves its
lane, and how far past the clipped car's front the striker's centre gets, at the most, while it is turned 60-120 deg
(an angle contact with a car in its lane). `--striker`, `--clipped` (m/s) and `--third` (factors on the clipped car's
speed) sweep other speeds; `--ignore-clipped` moves the clipped car's stepped path out of the way after the clip,
which tells whether the striker cannot reach the third car or the clipped car reaches it first.

Figures (dry road): the default sweep, 0 of 1116. Within the speeds of a queue whose cars are all sampled at
19.7-24.6 m/s, the clipped car slowed down to 0.6 of that (`timing.SPEED_SCALE`, clip.CLIP_SPEEDS) and the striker
at least 3 m/s faster (`--striker 19.7,21.5,23,24.5 --clipped 11.8,13.5,15.5,18,20`): 0 of 1186 with the third car
at 1-1.4 times the clipped car's speed; with it slower (`--third 0.6,0.7,0.8,0.9`) 0 too, and 578 of 1186 with
`--ignore-clipped`: the striker turned 60-120 deg reaches a slower third car, but the clipped car, pushed on by the
clip, is in the way.
"""
from __future__ import annotations

import argparse
import itertools
import sys

import numpy as np

from crashscene.geometry import footprints_overlap
from crashscene.simulate.backend import DEFAULT_DT
from crashscene.simulate.embedded import cascade, clipahead, swerve, timing
from crashscene.simulate.embedded.skid import Body
from crashscene.simulate.embedded.vehicles import limits_for

LENGTH, WIDTH, LANE = 4.6, 1.8, 3.5  # [m] a mid-size car, a lane
STRIKER_SPEEDS = (17.0, 21.0, 25.0, 29.0, 31.0)  # [m/s]
PARTNER_SPEEDS = (13.0, 17.0, 21.0, 25.0, 29.0)  # [m/s] the clipped car's (the striker at least 3 m/s faster)
THIRD_FACTORS = (1.0, 1.1, 1.25, 1.4)  # [-] the third car's speed on the clipped car's
PLACE_STEP = 0.25  # [m]
OUT_OF_THE_WAY = 100.0  # [m] --ignore-clipped moves the clipped car's path this far to the side


def _speeds(text: str) -> tuple[float, ...]:
    return tuple(float(v) for v in text.split(","))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--friction", type=float, default=0.8, help="tyre-road friction [-] (dry 0.8)")
    parser.add_argument("--class", dest="klass", default="angle", help="the written class of the later contact")
    parser.add_argument("--striker", type=_speeds, default=STRIKER_SPEEDS, help="the striker's speeds [m/s], a,b,...")
    parser.add_argument("--clipped", type=_speeds, default=PARTNER_SPEEDS, help="the clipped car's speeds [m/s]")
    parser.add_argument("--third", type=_speeds, default=THIRD_FACTORS,
                        help="the third car's speeds as factors [-] of the clipped car's")
    parser.add_argument("--ignore-clipped", action="store_true",
                        help="the clipped car's path after the clip moved out of the way (it reaches nothing)")
    args = parser.parse_args()
    lim = limits_for("car")
    spec = (LENGTH, WIDTH, lim.mass, lim.wheelbase_ratio)
    body = Body(LENGTH, WIDTH)
    dt = DEFAULT_DT
    n_clips = n_met = n_aside = 0
    reach = []
    for v1, v2 in itertools.product(args.striker, args.clipped):
        if v1 - v2 < 3.0:
            continue
        rows = swerve.paths([(v1, LANE, timing.lateral_rate("change_lane_left"), LENGTH * lim.wheelbase_ratio,
                              lim.steer_rate, lim.steer_max, dt)])[0]
        x, y, yaw = (q[0] for q in rows)
        clips = []
        for ahead in np.arange(LENGTH, 40.0, PLACE_STEP):
            px = ahead + v2 * dt * np.arange(1, len(x) + 1)
            touch = footprints_overlap(x, y, yaw, LENGTH, WIDTH, px, np.zeros_like(px), np.zeros_like(px), LENGTH,
                                       WIDTH)
            if touch.any():
                k = int(np.argmax(touch))
                clips.append(cascade.Clip((x, y, yaw), 1.0, v1, 0.0, float(ahead), v2, 0.0, (k + 1) * dt, dt, spec,
                                          spec, args.friction))
        pairs = clipahead.clip_pairs(clips)
        for clip, pair in zip(clips, pairs):
            if pair is None:
                continue
            n_clips += 1
            t_touch, mine, theirs = pair
            n_aside += bool(np.any(np.abs(theirs[1]) > LANE / 2))
            turned = np.abs(np.abs(np.degrees(mine[2])) - 90.0) <= 30.0
            in_lane = np.abs(mine[1]) < (WIDTH + LENGTH) / 2  # turned across, it reaches a car in the lane
            front = clip.partner_ahead + v2 * (t_touch + cascade.DT * np.arange(1, mine.shape[1] + 1)) + LENGTH / 2
            past = (mine[0] - front)[turned & in_lane]
            if len(past):
                reach.append(float(past.max()))
            if args.ignore_clipped:
                pair = (t_touch, mine, theirs + np.array([0.0, OUT_OF_THE_WAY, 0.0])[:, None])
            for factor in args.third:
                ahead = clipahead.Ahead(clip.partner_ahead + LENGTH, 0.0, v2 * factor, body, 0.0)
                if clipahead.place_ahead([pair], body, body, ahead, [clip.partner_ahead], args.klass, True):
                    n_met += 1
                    break
    print(f"friction {args.friction}: {n_clips} clips (striker {min(args.striker):g}-{max(args.striker):g} m/s, "
          f"clipped car {min(args.clipped):g}-{max(args.clipped):g} m/s); {n_met} meet a car ahead of the clipped one "
          f"first with class {args.klass} (its speed x{min(args.third):g}-{max(args.third):g} of the clipped car's, "
          f"any start ahead of it){' (the clipped car ignored)' if args.ignore_clipped else ''}")
    print(f"the clipped car's centre leaves its lane (more than {LANE / 2:g} m off its line within "
          f"{cascade.HORIZON:g} s of the clip) in {n_aside} of them")
    if reach:
        r = np.array(reach)
        print(f"striker turned 60-120 deg within reach of the clipped car's lane in {len(r)} clips: its centre past "
              f"the clipped car's front (driving on as before) by at most {r.max():.1f} m "
              f"(median {np.median(r):.1f} m)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
