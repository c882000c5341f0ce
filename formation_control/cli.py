"""Command line: ``formation-control sim SCENARIO.yaml ...`` runs the offline simulator."""
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


def cmd_sim(args):
    sc = scenario.load(find_scenario(args.scenario), args.param,
                       duration=args.duration, seed=args.seed)
    for note in sc.warnings:
        print(f'warning: {note}', file=sys.stderr)
    run = simulator.simulate(sc)
    out = simulator.summary(run)
    print(f'{args.scenario}: {sc.num_vehicles} vehicles, {sc.model} {sc.formation} '
          f'({sc.controller}), {out["duration"]:g} s simulated')
    _print_summary(out)
    if args.out:
        run.save(args.out)
        print(f'wrote {args.out}')
    if args.plot:
        from formation_control.plotting import plot_run
        plot_run(run, args.plot)
        print(f'wrote {args.plot}')
    if args.summary:
        Path(args.summary).write_text(json.dumps(out, indent=2))
    return 0


def build_parser():
    parser = argparse.ArgumentParser(prog='formation-control', description=__doc__)
    sub = parser.add_subparsers(dest='command', required=True)
    sim = sub.add_parser('sim', help='run a scenario in the offline simulator')
    sim.add_argument('scenario', help='scenario YAML (ROS 2 parameter file) or config name')
    sim.add_argument('--out', help='write the run to this .npz')
    sim.add_argument('--plot', help='write a figure to this .png')
    sim.add_argument('--summary', help='write the convergence figures to this .json')
    sim.add_argument('--duration', type=float, help='override duration (s)')
    sim.add_argument('--seed', type=int, help='override the random seed')
    sim.add_argument('-p', '--param', action='append', default=[], metavar='NAME:=VALUE',
                     help='override any scenario parameter (repeatable)')
    sim.set_defaults(func=cmd_sim)
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
