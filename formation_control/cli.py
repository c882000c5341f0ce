"""
Command line: ``formation-control sim`` runs the offline simulator, ``formation-control swarm``
runs a fleet as ROS 2 processes (plant + one process per vehicle).
"""
import argparse
import json
from pathlib import Path
import sys

from formation_control.core import scenario, simulator


def find_scenario(name):
    """A scenario path, or the name of a file shipped in the package's config/ directory."""
    path = Path(name)
    if path.exists():
        return path
    stem = path.name if path.suffix else path.name + '.yaml'
    source_tree = Path(__file__).resolve().parents[1] / 'config' / stem
    if source_tree.exists():
        return source_tree
    try:
        from ament_index_python.packages import get_package_share_directory
        candidate = Path(get_package_share_directory('formation_control')) / 'config' / stem
    except (ImportError, LookupError, OSError):
        candidate = None
    if candidate is not None and candidate.exists():
        return candidate
    raise scenario.ScenarioError(f'scenario {name!r} not found (a path, or one of config/*.yaml)')


def _print_summary(out):
    for key, value in out.items():
        text = f'{value:.6g}' if isinstance(value, float) else value
        print(f'  {key:18s} {text}')


def _load(args):
    sc = scenario.load(find_scenario(args.scenario), args.param,
                       duration=args.duration, seed=args.seed)
    for note in sc.warnings:
        print(f'warning: {note}', file=sys.stderr)
    return sc


def _report(args, sc, out, what):
    print(f'{args.scenario}: {sc.num_vehicles} vehicles, {sc.model} {sc.formation} '
          f'({sc.controller}), {out["duration"]:g} s simulated {what}')
    _print_summary(out)
    if args.summary:
        Path(args.summary).write_text(json.dumps(out, indent=2))


def _write(args, run):
    if args.out:
        run.save(args.out)
        print(f'wrote {args.out}')
    if args.plot:
        from formation_control.plotting import plot_run
        plot_run(run, args.plot)
        print(f'wrote {args.plot}')


def cmd_sim(args):
    sc = _load(args)
    run = simulator.simulate(sc)
    _report(args, sc, simulator.summary(run), 'offline')
    _write(args, run)
    return 0


def cmd_swarm(args):
    from formation_control import swarm
    sc = _load(args)
    note = swarm.environment_note()
    if note:
        print(note, file=sys.stderr)
    try:
        run, out = swarm.run_swarm(sc, args.mode, args.bag, args.real_time_factor, args.timeout)
    except KeyboardInterrupt:
        print('interrupted: every process of the fleet was stopped', file=sys.stderr)
        return 0
    except (RuntimeError, TimeoutError, FileExistsError, FileNotFoundError) as err:
        print(f'error: {err}', file=sys.stderr)
        return 1
    _report(args, sc, out, f'as ROS 2 processes ({args.mode})')
    _write(args, run)
    return 0


def _scenario_arguments(parser):
    parser.add_argument('scenario', help='scenario YAML (ROS 2 parameter file) or config name')
    parser.add_argument('--summary', help='write the convergence figures to this .json')
    parser.add_argument('--duration', type=float, help='override duration (s)')
    parser.add_argument('--seed', type=int, help='override the random seed')
    parser.add_argument('-p', '--param', action='append', default=[], metavar='NAME:=VALUE',
                        help='override any scenario parameter (repeatable)')
    parser.add_argument('--out', help='write the run to this .npz')
    parser.add_argument('--plot', help='write a figure to this .png')


def build_parser():
    parser = argparse.ArgumentParser(prog='formation-control', description=__doc__)
    sub = parser.add_subparsers(dest='command', required=True)
    sim = sub.add_parser('sim', help='run a scenario in the offline simulator')
    _scenario_arguments(sim)
    sim.set_defaults(func=cmd_sim)
    swarm = sub.add_parser('swarm', help='run a scenario as ROS 2 processes, one per vehicle')
    _scenario_arguments(swarm)
    swarm.add_argument('--mode', choices=('lockstep', 'realtime'), default='lockstep')
    swarm.add_argument('--real-time-factor', type=float, default=1.0,
                       help='realtime mode: simulated seconds per wall second')
    swarm.add_argument('--bag', help='record every topic to this new rosbag2 directory (MCAP)')
    swarm.add_argument('--timeout', type=float,
                       help='give up after this many wall seconds (default 60 + 20 x duration)')
    swarm.set_defaults(func=cmd_swarm)
    return parser


def main(argv=None):
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except scenario.ScenarioError as err:
        print(f'error: {err}', file=sys.stderr)
        return 2


if __name__ == '__main__':
    sys.exit(main())
