# Copyright 2026 formation_control developers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
Command line: the ``formation-control`` commands (sim, swarm, report, play, repair, ...).

``sim`` runs the offline simulator, ``swarm`` runs a fleet as ROS 2 processes (plant + one
process per vehicle + monitor); ``set`` changes run-time gains on every vehicle of a running
fleet; ``plot`` and ``report`` read a run back from a simulator/plant ``.npz`` or a rosbag2
bag; ``play`` republishes a bag; ``repair`` makes a bag its recorder did not close readable;
``doctor`` checks a running fleet; ``sweep`` runs a grid of
parameter values x seeds; ``params`` prints the table of scenario parameters
(docs/parameters.md); ``layout`` prints the Foxglove layout (foxglove/formation_control.json).
"""
import argparse
import json
from pathlib import Path
import signal
import socket
import sys
import threading
import zipfile

from formation_control.core import parameters, scenario
from formation_control.core.errors import UsageError
from formation_control.ops import security
from formation_control.protocol import names, node_parameters
from formation_control.protocol.healing import HEAL_AFTER
from formation_control.sim import report, simulator


SIZES = ('num_vehicles', 'duration', 'record_dt')   # the parameters a run's memory grows with


def _split(overrides):
    """(scenario overrides, node overrides): link and frame parameters go to the nodes only."""
    from formation_control.protocol.links import PARAMETERS
    names = set(PARAMETERS) | set(node_parameters.FRAMES)
    node = [o for o in overrides if o.split(':=', 1)[0].strip() in names]
    return [o for o in overrides if o not in node], node


def _load(args, node_params_allowed=False):
    overrides, node = _split(args.param)
    if node and not node_params_allowed:
        raise UsageError(
            f"{', '.join(node)}: link and frame parameters apply to the ROS nodes only (use "
            f'swarm)')
    sc = scenario.load(parameters.find(args.scenario), overrides,
                       duration=args.duration, seed=args.seed)
    for note in sc.warnings:
        print(f'warning: {note}', file=sys.stderr)
    return sc


def _report(run, source, what, extra=None, summary_path=None):
    sc = run.sc
    out, rows = report.report(run)
    out.update(extra or {})
    out['final'] = {name: value for name, value, _, _ in rows}
    out['predicted'] = {name: pred for name, _, pred, _ in rows if pred is not None}
    title = (f'{source}: {sc.num_vehicles} vehicles, {sc.model} {sc.formation} '
             f'({sc.controller}), {out["duration"]:g} s {what}')
    print(report.format_report(title, out, rows))
    for key, value in (extra or {}).items():
        if key in ('faults', 'lost', 'healed') or key.startswith('survivors'):
            continue
        text = f'{value:.4g}' if isinstance(value, float) else value
        print(f'  {key:20s} {text}')
    if extra and 'lost' in extra:
        print('\n'.join(_fault_lines(extra)))
    if summary_path:
        Path(summary_path).write_text(json.dumps(out, indent=2))


def _write(args, run):
    if args.out:
        run.save(args.out)
        print(f'wrote {args.out}')
    if args.plot:
        from formation_control.sim.plotting import plot_run
        plot_run(run, args.plot)
        print(f'wrote {args.plot}')


def cmd_sim(args):
    sc = _load(args)
    run = simulator.simulate(sc)
    _report(run, args.scenario, 'simulated offline', summary_path=args.summary)
    _write(args, run)
    return 0


def cmd_sweep(args):
    import os
    from formation_control.sim import sweep
    base = parameters.read_params(parameters.find(args.scenario))
    if args.duration is not None:
        base['duration'] = args.duration
    workers = os.cpu_count() if args.workers is None else args.workers
    if workers < 0:
        raise sweep.SweepError(f'--workers = {workers} must be >= 0 (0: in this process)')
    try:
        the_plan = sweep.plan(base, args.param, range(args.first_seed,
                                                      args.first_seed + args.seeds),
                              args.batch_size, workers)
        where = 'on ' + args.scheduler if args.scheduler else f'{workers} local worker(s)'
        print(f'{args.scenario}: {len(the_plan.points)} grid point(s) x {len(the_plan.seeds)} '
              f'seeds = {the_plan.runs} runs in {len(the_plan.batches)} batches, {where}',
              file=sys.stderr)
        failures = sweep.execute(the_plan, args.out, workers, args.scheduler, args.resume,
                                 progress=sweep.Progress(the_plan.runs))
    except sweep.SweepError as err:
        raise UsageError(str(err)) from None
    except KeyboardInterrupt:
        print(f'\ninterrupted: the batches done are in {sweep.parts_dir(args.out)}; the same '
              f'command with --resume continues', file=sys.stderr)
        return 130
    if failures:
        for i, reason in sorted(failures.items()):
            print(f'error: batch {i} failed twice: {reason}', file=sys.stderr)
        print(f'the other batches are in {sweep.parts_dir(args.out)}: run the same command '
              f'with --resume to retry the failed ones', file=sys.stderr)
        return 1
    data = sweep.merge(the_plan, args.out)
    print(sweep.format_table(sweep.table(data)))
    print(f'wrote {args.out}')
    if args.plot:
        sweep.plot(data, args.plot, f'{args.scenario}: {len(the_plan.seeds)} seeds per point, '
                                    f'{base.get("duration", 60.0):g} s')
        print(f'wrote {args.plot}')
    return 0


def cmd_swarm(args):
    from formation_control import swarm
    stop, caught = threading.Event(), []             # SIGINT, SIGTERM: stop the fleet
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda signum, _: (caught.append(signum), stop.set()))
    if args.foxglove is not None and (args.no_monitor or not 0 < args.foxglove < 65536):
        raise UsageError(f'--foxglove {args.foxglove} is invalid: a TCP port in '
                         f'1..65535, served by the monitor (not with --no-monitor)')
    sc = _load(args, node_params_allowed=True)
    note = swarm.environment_note()
    if note:
        print(note, file=sys.stderr)
    if args.restart_dead is not None and not args.restart_dead >= 0:
        raise UsageError(f'--restart-dead {args.restart_dead:g} is invalid: a delay '
                         f'in fleet seconds, >= 0')
    if not args.heal_after >= 0:
        raise UsageError(f'--heal-after {args.heal_after:g} is invalid: wall seconds, '
                         f'>= 0 (0: never heal)')
    try:
        options = swarm.SwarmOptions(
            real_time_factor=args.real_time_factor, monitor=not args.no_monitor,
            node_params=tuple(_split(args.param)[1]),
            monitor_params=tuple(_live_view(args.foxglove, args.namespace)),
            restart_dead=args.restart_dead, secure=args.secure, heal_after=args.heal_after,
            stop=stop)
        run, out = swarm.run_swarm(sc, options, args.mode, args.vehicles_per_process,
                                   args.namespace, args.bag, args.fault, args.timeout)
    except KeyboardInterrupt:
        print('interrupted: every process of the fleet was stopped', file=sys.stderr)
        return 128 + (caught[0] if caught else signal.SIGINT)
    except (RuntimeError, TimeoutError, FileExistsError, FileNotFoundError) as err:
        print(f'error: {err}', file=sys.stderr)
        return 1
    extra = {k: out[k] for k in ('mode', 'real_time_factor', 'logs', 'bag', 'faults', 'lost',
                                 'healed', 'survivors', 'survivors_converged',
                                 'survivors_convergence_time') if k in out}
    _report(run, args.scenario, 'as ROS 2 processes', extra, args.summary)
    _write(args, run)
    failed = sorted({p['process'] for p in out['lost']
                     if p['cause'] == 'not scripted' and p['restarted'] is None})
    if failed:
        print(f"error: {', '.join(failed)} exited (not scripted) and did not come back: the "
              f"run failed; their logs are in {out['logs']}", file=sys.stderr)
        return 1
    return 0


def _fault_lines(out):
    """Return the summary lines of a swarm's faults and lost processes."""
    def at(t):
        return '?' if t is None else f'{t:.2f} s'
    lines = [f'  fault {f["fault"]:18s} {f["action"]}, applied at t = {at(f["applied"])}'
             for f in out['faults']]
    for p in out['lost']:
        again = '' if p['restarted'] is None else f', restarted at t = {at(p["restarted"])}'
        lines.append(f'  lost  {p["process"]:18s} at t = {at(p["time"])} (exit '
                     f'{p["exit"]}, {p["cause"]}){again}')
    lines += [f'  healed {h["process"]:17s} at t = {at(h["time"])}: {h["reason"]}'
              for h in out.get('healed', ())]
    if out['lost'] or out['faults']:
        since = out['survivors_convergence_time']
        state = 'not converged' if not out['survivors_converged'] else (
            f'converged at {since:.2f} s' if since is not None else 'converged')
        lines.append(f'  survivors {out["survivors"]}: {state}')
    return lines


def _live_view(port, namespace='/'):
    """Return the monitor parameters of ``swarm --foxglove PORT`` and say where to connect."""
    if port is None:
        return []
    with socket.socket() as probe:                    # as the live view binds it
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind(('127.0.0.1', port))
        except OSError as err:
            raise UsageError(f'--foxglove {port}: cannot serve the Foxglove live view on '
                             f'127.0.0.1:{port} ({err.strerror}): give a free port') from None
    ns = names.namespace_of(namespace)
    layout = 'formation-control layout' + (f' --namespace {ns}' if ns != '/' else '')
    print(f'Foxglove live view: open ws://127.0.0.1:{port} in the Foxglove app, Foxglove Studio '
          f'or Lichtblick (layout: {layout}, --format classic for Studio and Lichtblick)',
          file=sys.stderr)
    return [f'foxglove_port:={port}']


def cmd_set(args):
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    from formation_control.ros import tuning
    params = tuning.parse(args.assignments)
    context = rclpy.Context()
    rclpy.init(context=context, signal_handler_options=rclpy.SignalHandlerOptions.NO)
    try:
        node = rclpy.create_node('formation_control_set', context=context,
                                 start_parameter_services=False)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        tuner = tuning.FleetTuner(node, executor, args.namespace)
        results = tuner.apply(params, args.timeout)
    finally:
        context.try_shutdown()
    lines, everyone = tuning.report(params, results)
    print('\n'.join(lines))
    return 0 if everyone else 1


def load_source(path):
    """Return the run of a simulator/plant ``.npz`` or of a rosbag2 bag directory."""
    if Path(path).is_dir() and (Path(path) / 'metadata.yaml').exists():
        from formation_control.bags import reader as bagfile  # only bags need rosbags
        run = bagfile.read_run(path)
        skipped = run.meta['skipped']
        if skipped:
            print(f'{path}: left out {sum(skipped.values())} samples no node takes '
                  f'(undecodable or not finite): '
                  + ', '.join(f'{t} {n}' for t, n in sorted(skipped.items())), file=sys.stderr)
        return run
    if Path(path).is_file():
        try:
            return simulator.load_run(path)
        except (OSError, ValueError, KeyError) as err:
            reason = err if zipfile.is_zipfile(path) else 'no .npz archive'
            raise UsageError(f'{path}: not a run .npz ({reason}); the run is the .npz of '
                             f'--out or a bag directory (a --summary .json is printed '
                             f'already)') from None
    from formation_control.bags.repair import unclosed
    raise UsageError(unclosed(path) or f'SOURCE {path!r} is neither a run .npz nor a rosbag2 '
                     f'bag directory (one with metadata.yaml)')


def cmd_plot(args):
    from formation_control.sim.plotting import plot_run
    plot_run(load_source(args.source), args.out)
    print(f'wrote {args.out}')
    return 0


def cmd_report(args):
    _report(load_source(args.source), args.source, 'recorded', summary_path=args.summary)
    return 0


def cmd_repair(args):
    from formation_control.bags.repair import repair
    try:
        kept = repair(args.bag, args.out)
    except OSError as err:
        print(f'error: writing the repaired bag failed ({err}): free some room, or give '
              f'--out DIR on another disk', file=sys.stderr)
        return 1
    print(f'repaired {args.out or args.bag}' + ('' if args.out else
                                                f' (the original: {args.bag}.unrepaired)'))
    print('\n'.join(kept.lines()))
    return 0


def cmd_params(args):
    print(parameters.markdown() + node_parameters.markdown(), end='')
    return 0


def cmd_play(args):
    from formation_control.bags.playback import Bag, BagError, CLOCK_TOPIC
    args.namespace = names.namespace_of(args.namespace)
    try:
        if not args.rate > 0:
            raise BagError(f'--rate {args.rate} is invalid: must be > 0')
        bag = Bag(args.bag, args.topics, skip=(CLOCK_TOPIC,) if args.clock else (),
                  namespace=args.namespace)
    except BagError as err:
        print(f'error: {err}', file=sys.stderr)
        return 2
    from formation_control.ros.player import PlayerNode
    from formation_control.ros.runner import run
    nodes = []

    def make(context):
        nodes.append(PlayerNode(bag, args.rate, args.clock, args.loop,
                                args.wait_for_subscribers, namespace=args.namespace,
                                context=context))
        return nodes[0]
    code = run(make, args.ros_args)
    error = nodes[0].error if nodes else None
    if error is not None:
        print(f'error: {error}', file=sys.stderr)
        return 1
    return code


def cmd_doctor(args):
    from formation_control.ops.doctor import exit_status, format_report
    from formation_control.ros.doctor import run
    facts, findings = run(args.namespace, args.listen, args.discover)
    print(format_report(facts, findings), end='')
    return exit_status(findings)


def cmd_secure(args):
    if args.target[0] == 'revoke':
        return _revoke(args.target[1:])
    if len(args.target) != 1 or args.vehicles is None:
        raise UsageError('secure: give DIR --vehicles N (make a fleet), or revoke MEMBER DIR')
    directory = args.target[0]
    fleet = security.roster(args.vehicles, security.parse_hosts(args.host), args.base_port)
    homes = security.write_fleet(directory, fleet, args.organisation, args.days,
                                 args.root, signing=not args.no_signing)
    for member, home in zip(fleet, homes):
        at = member.address + (' (connects only)' if member.port is None else f':{member.port}')
        print(f'{member.name:<12} {at:<27} {home}')
    print(f'CA: {Path(directory).resolve() / "ca"} (keep ca.key off the fleet). Copy each '
          f'member directory to its host; there, `. MEMBER/env.sh` before `ros2 run`, or '
          f'`formation-control swarm ... --secure {directory}` on one host.')
    return 0


def _revoke(words):
    from formation_control.ops import signing
    if len(words) != 2:
        raise UsageError('secure revoke: give MEMBER DIR (the member, the fleet directory)')
    name, directory = words
    revoked = signing.revoke(Path(directory), name)
    print(f'revoked: {", ".join(revoked)}; the list is {Path(directory).resolve() / "ca"}/'
          f"{security.CRL} and each member directory's {security.CRL} (copy them out: a "
          f'running member reloads it within a second)')
    return 0


def cmd_layout(args):
    from formation_control.view.layout import layout_json
    text = layout_json(args.namespace, args.world_frame, args.format)
    if args.out:
        Path(args.out).write_text(text)
        print(f'wrote {args.out}')
    else:
        print(text, end='')
    return 0


def _scenario_arguments(parser):
    parser.add_argument('scenario', help='scenario YAML (ROS 2 parameter file) or config name')
    parser.add_argument('--summary', help='write the convergence figures to this .json')
    parser.add_argument('--duration', type=float, help='override duration (s)')
    parser.add_argument('--seed', type=int, help='override the random seed')
    parser.add_argument('-p', '--param', action='append', default=[], metavar='NAME:=VALUE',
                        help='override any scenario parameter (repeatable); swarm also takes '
                             'the link parameters of the nodes (neighbor_timeout, '
                             'drop_probability, delay, ...)')
    parser.add_argument('--out', help='write the run to this .npz')
    parser.add_argument('--plot', help='write a figure to this .png')


def _namespace(parser, text):
    parser.add_argument('--namespace', default='/', metavar='NS', help=text)


def _sim_parser(sub):
    sim = sub.add_parser('sim', help='run a scenario in the offline simulator')
    _scenario_arguments(sim)
    sim.set_defaults(func=cmd_sim)


def _sweep_parser(sub):
    sweep = sub.add_parser('sweep', help='Monte-Carlo study: a grid of parameter values x '
                           'seeds, in batches on local workers or a Dask cluster')
    sweep.add_argument('scenario', help='scenario YAML (ROS 2 parameter file) or config name')
    sweep.add_argument('--seeds', type=int, default=100, help='runs per grid point (seeds '
                       'FIRST..FIRST+SEEDS-1; default 100)')
    sweep.add_argument('--first-seed', type=int, default=0, metavar='FIRST')
    sweep.add_argument('-p', '--param', action='append', default=[], metavar='NAME:=VALUE',
                       help='a fixed value, or a grid axis: NAME:=[v1, v2, ...] (flow and c0: '
                       'a list of pairs)')
    sweep.add_argument('--duration', type=float, help='override duration (s)')
    sweep.add_argument('--out', default='sweep.npz', help='the results, one row per run '
                       '(default sweep.npz; batches go to OUT.parts/ as they complete)')
    sweep.add_argument('--plot', help='write the figure to this .png')
    sweep.add_argument('--workers', type=int, help='local worker processes (default: one per '
                       'core; 0: in this process)')
    sweep.add_argument('--scheduler', metavar='tcp://HOST:PORT',
                       help='run the batches on this Dask distributed scheduler')
    sweep.add_argument('--batch-size', type=int, help='runs simulated together (default: '
                       '2000 vehicles, at least two batches per worker)')
    sweep.add_argument('--resume', action='store_true',
                       help='continue the sweep whose batches are in OUT.parts/')
    sweep.set_defaults(func=cmd_sweep)


def _swarm_parser(sub):
    swarm = sub.add_parser('swarm', help='run a scenario as ROS 2 processes, one per vehicle')
    _scenario_arguments(swarm)
    swarm.add_argument('--mode', choices=('lockstep', 'realtime'), default='lockstep')
    swarm.add_argument('--real-time-factor', type=float, default=1.0,
                       help='realtime mode: simulated seconds per wall second')
    swarm.add_argument('--bag', help='record every topic to this new rosbag2 directory (MCAP)')
    swarm.add_argument('--timeout', type=float,
                       help='give up after this many wall seconds (default 60 + 20 x duration)')
    swarm.add_argument('--vehicles-per-process', default='auto', metavar='M',
                       help='run M vehicle nodes per process (still one node per vehicle, '
                            'talking through topics only); auto (the default): 1 with --secure '
                            'or a process fault, else the fleet over one process per core')
    swarm.add_argument('--foxglove', type=int, metavar='PORT',
                       help="serve a Foxglove live view on this port (the monitor's "
                            'foxglove_port)')
    swarm.add_argument('--no-monitor', action='store_true',
                       help='do not start the monitor node (no metrics or diagnostics)')
    _namespace(swarm, 'run the fleet in this ROS namespace (default /)')
    swarm.add_argument('--fault', action='append', default=[], metavar='FAULT',
                       help='a scripted fault in fleet time (repeatable): kill:K@T, '
                            'restart:K@T, stop:K@T (SIGSTOP: vehicle K freezes), cont:K@T '
                            '(SIGCONT), cut:I-J@T1..T2 (the link between neighbours I and J '
                            'is down from T1 to T2 s)')
    swarm.add_argument('--restart-dead', type=float, metavar='DELAY',
                       help='start a vehicle or monitor process that died by itself again, '
                            'DELAY fleet seconds later (default: never)')
    swarm.add_argument('--heal-after', type=float, default=HEAL_AFTER, metavar='SECONDS',
                       help='restart a live process the fleet has waited on this many wall '
                            'seconds (a member that never joined, or wedged; at most 3 times; '
                            f'0: never; default {HEAL_AFTER:g})')
    swarm.add_argument('--secure', metavar='DIR',
                       help='run every process as its member of the TLS fleet made by '
                            '`formation-control secure DIR` (docs/security.md)')
    swarm.set_defaults(func=cmd_swarm)


def _secure_parser(sub):
    sec = sub.add_parser('secure', help='make a fleet only its members can join: a CA, a key '
                                        'and certificate per member, Fast DDS TLS profiles '
                                        '(docs/security.md)')
    sec.add_argument('target', nargs='+', metavar='DIR | revoke MEMBER DIR',
                     help='DIR: write the fleet here (kept: its CA and member keys); revoke '
                          "MEMBER DIR: add MEMBER's certificate to the fleet's revocation list "
                          '(signed by its CA), which every member checks at start-up and '
                          'reloads when it changes')
    sec.add_argument('--vehicles', type=int, metavar='N',
                     help='members vehicle_1..vehicle_N (plus plant, monitor, swarm, operator)')
    sec.add_argument('--host', action='append', default=[], metavar='NAME=ADDRESS',
                     help='the IPv4 address member NAME is reached at (repeatable; default '
                          '127.0.0.1)')
    sec.add_argument('--base-port', type=int, default=7900, metavar='PORT',
                     help='the plant listens for TLS on TCP PORT, the monitor on PORT + 1, '
                          'the swarm on PORT + 2, vehicle k on PORT + 2 + k (default 7900)')
    sec.add_argument('--root', metavar='PATH',
                     help="DIR's path on the hosts, which the profiles name (default: DIR)")
    sec.add_argument('--days', type=int, default=365, help='certificate validity (days)')
    sec.add_argument('--organisation', default='formation_control fleet',
                     help="the certificates' organisation (O=)")
    sec.add_argument('--no-signing', action='store_true',
                     help='members do not sign their control topics (any member may then pose '
                          'as another; docs/security.md): for comparison')
    sec.set_defaults(func=cmd_secure)


def _set_parser(sub):
    tune = sub.add_parser('set', help='set run-time parameters (gains) on every vehicle of a '
                                      'running fleet')
    tune.add_argument('assignments', nargs='+', metavar='NAME:=VALUE',
                      help='run-time scenario parameters (docs/parameters.md, "run time")')
    _namespace(tune, "the fleet's namespace")
    tune.add_argument('--timeout', type=float, default=10.0,
                      help='seconds to wait for the fleet (default 10)')
    tune.set_defaults(func=cmd_set)


def _plot_parser(sub):
    plot = sub.add_parser('plot', help='draw the figures of a run (.npz or bag)')
    plot.add_argument('source', help='a run .npz (sim --out, swarm --out) or a bag directory')
    plot.add_argument('--out', required=True, help='PNG file to write')
    plot.set_defaults(func=cmd_plot)


def _report_parser(sub):
    rep = sub.add_parser('report', help='convergence and steady state of a run (.npz or bag)')
    rep.add_argument('source', help='a run .npz (sim --out, swarm --out) or a bag directory')
    rep.add_argument('--summary', help='write the figures to this .json')
    rep.set_defaults(func=cmd_report)


def _repair_parser(sub):
    fix = sub.add_parser('repair', help='make a bag its recorder did not close readable again '
                                        '(summary, index, metadata.yaml); says what was kept')
    fix.add_argument('bag', help='the bag directory (one .mcap, metadata.yaml or none)')
    fix.add_argument('--out', metavar='DIR',
                     help='write the repaired bag to this new directory and leave BAG as it '
                          'is (default: in place, the original kept as BAG.unrepaired)')
    fix.set_defaults(func=cmd_repair)


def _params_parser(sub):
    params = sub.add_parser('params', help='print the table of scenario parameters (Markdown, '
                                           'docs/parameters.md)')
    params.set_defaults(func=cmd_params)


def _play_parser(sub):
    play = sub.add_parser('play', help='republish a rosbag2 bag with its recorded QoS, like '
                                       '`ros2 bag play`',
                          epilog='Arguments after --ros-args go to the player node (e.g. '
                                 'remappings: --ros-args -r /clock:=/other_clock).')
    play.add_argument('bag', help='the bag directory (any rosbag2 bag: MCAP or sqlite3)')
    play.add_argument('--rate', type=float, default=1.0,
                      help='recorded seconds per wall second (default 1)')
    _namespace(play, "the fleet's namespace: relative --topics names and --clock's "
               '<NS>/clock resolve in it (default /)')
    play.add_argument('--clock', action='store_true',
                      help='publish <NS>/clock with the recorded time being played (for nodes '
                           "with use_sim_time); the bag's own <NS>/clock is not replayed")
    play.add_argument('--topics', nargs='+', metavar='TOPIC',
                      help='replay these topics only: absolute (/fleet_a/vehicle_1/odom) or '
                           'relative to --namespace (vehicle_1/odom)')
    play.add_argument('--loop', action='store_true', help='start again at the end, until SIGINT')
    play.add_argument('--wait-for-subscribers', action='store_true',
                      help='hold the start until every replayed topic has a subscriber')
    play.set_defaults(func=cmd_play)


def _doctor_parser(sub):
    doc = sub.add_parser('doctor', help='join the domain and report what keeps a fleet from '
                                        'working (exit 1 if anything)')
    _namespace(doc, "the fleet's namespace: its plant, vehicles and topics (default /)")
    doc.add_argument('--listen', type=float, default=2.0,
                     help='seconds to listen to the formation states (default 2)')
    doc.add_argument('--discover', type=float, default=5.0,
                     help="seconds to wait for the plant's scenario (default 5)")
    doc.set_defaults(func=cmd_doctor)


def _layout_parser(sub):
    lay = sub.add_parser('layout', help='print the Foxglove layout of a fleet (JSON, '
                                        'foxglove/formation_control[.classic].json)')
    _namespace(lay, "the fleet's namespace: the topics are its absolute names (default /)")
    lay.add_argument('--world-frame', default=node_parameters.WORLD_FRAME, metavar='FRAME',
                     help="the 3D panel's frame: the monitor's world_frame (default map)")
    lay.add_argument('--format', choices=('foxglove', 'classic'), default='foxglove',
                     help="foxglove: the Foxglove app's format (default); classic: Foxglove "
                          'Studio 1.x and Lichtblick (configById and a mosaic layout)')
    lay.add_argument('--out', help='write it to this file instead')
    lay.set_defaults(func=cmd_layout)


SUBCOMMANDS = (_sim_parser, _sweep_parser, _swarm_parser, _secure_parser, _set_parser,
               _plot_parser, _report_parser, _repair_parser, _params_parser, _play_parser,
               _doctor_parser, _layout_parser)
"""The parser of each subcommand, in the order of the help."""


def build_parser():
    parser = argparse.ArgumentParser(prog='formation-control', description=__doc__)
    sub = parser.add_subparsers(dest='command', required=True)
    for add in SUBCOMMANDS:
        add(sub)
    return parser


def main(argv=None):
    argv = list(sys.argv[1:] if argv is None else argv)
    cut = argv.index('--ros-args') if '--ros-args' in argv else len(argv)
    parser = build_parser()
    args = parser.parse_args(argv[:cut])
    args.ros_args = argv[cut:]
    if args.ros_args and args.command != 'play':
        parser.error('--ros-args: only play takes them (swarm: -p NAME:=VALUE)')
    try:
        return args.func(args)
    except (scenario.ScenarioError, UsageError, security.SecurityError) as err:
        print(f'error: {err}', file=sys.stderr)
        return 2
    except MemoryError as err:
        print(f'error: {out_of_memory(args, err)}', file=sys.stderr)
        return 2


def out_of_memory(args, err):
    """Return the one line that reports a MemoryError of a command: what, and what to lower."""
    what = str(err) or 'an allocation failed'
    given = [o for o in getattr(args, 'param', []) if o.split(':=', 1)[0].strip() in SIZES]
    if getattr(args, 'duration', None) is not None:
        given.append(f'--duration {args.duration:g}')
    hint = ('lower num_vehicles or --duration, or raise record_dt (fewer samples are kept)'
            + (', or lower --batch-size or --workers' if args.command == 'sweep' else ''))
    return (f'out of memory in {args.command}: {what}'
            + (f" (with {', '.join(given)})" if given else '') + f': {hint}')


if __name__ == '__main__':
    sys.exit(main())
