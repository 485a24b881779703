"""``paa-mj reproduce``: the paper redone, with figures, report and video."""
from __future__ import annotations

from .folders import output_lock
from .common import folder, note


def cmd_reproduce(args):
    from ..errors import PaaError
    from ..outputs.reproduce import reproduce

    gl_backend = None
    if args.gl is not None and args.no_video:
        raise PaaError("--gl chooses the backend of the video, which --no-video skips")
    if args.quick and args.full:
        raise PaaError("--quick and --full contradict each other: choose one size")
    if not args.no_video:
        from ..view.gl import select_backend

        try:
            gl_backend = select_backend(args.gl or "auto")
        except PaaError as err:
            note(f"warning: no video: {err}")
    import time

    started = time.perf_counter()
    with output_lock(args.out, "reproduce"):
        report = reproduce(args.out, video=gl_backend is not None,
                           size="quick" if args.quick else "full" if args.full else "default")
    print(f"report: {report} (in {time.perf_counter() - started:.0f} s)")
    return 0


def register(sub, parser_class):
    p = sub.add_parser("reproduce", help="redo the paper: simulations, figures 5-14, the open questions, report, video",
                       description="Redo every computation of the paper, write the figures, results.json and"
                                   " report.md (our numbers beside the paper's), and the video of the kip.")
    p.add_argument("--out", type=folder, default="out/reproduction", metavar="DIR", help="output folder")
    p.add_argument("--quick", action="store_true", help="the smallest studies (for tests; the verdicts may differ)")
    p.add_argument("--full", action="store_true",
                   help="the studies at full size (sensitivity 200 runs per size, candidate reading 50, basin 32 x 32;"
                        " about 10 CPU-minutes against 2 by default)")
    p.add_argument("--no-video", action="store_true", help="skip the video")
    p.add_argument("--gl", choices=("auto", "egl", "osmesa"), help="GL backend for the video (default: auto)")
    p.set_defaults(func=cmd_reproduce)
