"""``paa-mj peers``: paa_mj against Drake, for the dynamics and for Spong's acrobot swing-up."""
from __future__ import annotations

from .folders import output_lock
from .common import folder, positive, positive_int, print_json, seed


def cmd_peers(args):
    from ..studies.drake import require_drake

    require_drake()  # before anything else: one line that says how to install it
    from ..outputs.peers import write_peers
    from ..studies.peers import peers

    with output_lock(args.out, "peers"):
        t_final = args.t_final if args.t_final is not None else 3.0 if args.quick else 30.0
        summary = peers(t_final=t_final, samples=args.samples, seed=args.seed, quick=args.quick,
                        progress=not args.json)
        text = write_peers(args.out, summary)
    if args.json:
        print_json(summary)
    else:
        print(text)
    return 0


def register(sub, parser_class):
    p = sub.add_parser("peers", help="paa_mj against Drake: the dynamics, and Spong's acrobot swing-up closed loop",
                       description="Drake's MultibodyPlant loading paa_mj's MJCF files against the analytic model and"
                                   " MuJoCo (M, H, G, P, accelerations at random states), and Drake's AcrobotPlant"
                                   " with its AcrobotSpongController against paa_mj's spong on models/acrobot.xml in"
                                   " MuJoCo, with and without a zero-order hold. Needs Drake:"
                                   ' pip install "paa_mj[peers]".')
    p.add_argument("--out", type=folder, required=True, metavar="DIR",
                   help="folder for peers.json, peers.md and peers_closed_loop.png/.svg")
    p.add_argument("--t-final", type=positive, metavar="T", help="duration of each closed loop [s] (default: 30, as Drake's example scenario; 3 with --quick)")
    p.add_argument("--samples", type=positive_int, default=200, metavar="N", help="random states per robot for the dynamics")
    p.add_argument("--seed", type=seed, default=0, metavar="SEED", help="seed of the random states and chains")
    p.add_argument("--quick", action="store_true",
                   help="two robots and one random chain, two starts over 3 s, two time steps without the hold (for tests)")
    p.add_argument("--json", action="store_true", help="print everything as one JSON object on stdout")
    p.set_defaults(func=cmd_peers)
