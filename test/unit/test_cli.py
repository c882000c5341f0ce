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
The ``formation-control`` console script, run as a real subprocess on short scenarios.

Its printed figures, the .npz / .png / .json it writes, and exit code 2 for a bad scenario.
"""
import json
import os
from pathlib import Path
import resource
import struct
import subprocess
import sys

from formation_control import cli
from formation_control.core.control import Controller
from formation_control.core.models import ROW_OMEGA, ROW_U, ROW_V
from formation_control.core.scenario import initial_state, load, resolve
from formation_control.sim import simulator
import numpy as np
import pytest

CLI = Path(sys.executable).parent / 'formation-control'
CONFIG = Path(__file__).resolve().parents[2] / 'config'
STATE_KEYS = ('x', 'y', 'theta', 'omega', 'u', 'v')
SUMMARY_KEYS = {'num_vehicles', 'duration', 'converged', 'unmet', 'convergence_time',
                'held', 'hold_window', 'order_parameter', 'lyapunov', 'max_turn_rate', 'final',
                'predicted', 'separation'}
PARTICLE_OVERRIDES = ['num_vehicles:=4', 'duration:=5.0', 'flow:=[0.2, 0.1]', 'kappa:=4.0']
AMENT_CASES = pytest.mark.parametrize('ament', [
    pytest.param(True, id='ament_prefix_set'),
    pytest.param(False, id='ament_prefix_unset')])


def run_cli(cwd, *args, ament=True):
    env = dict(os.environ, MPLBACKEND='Agg')
    env.pop('AMENT_PREFIX_PATH', None)
    if ament:
        prefix = cwd / 'empty_ament_prefix'
        prefix.mkdir(exist_ok=True)
        env['AMENT_PREFIX_PATH'] = str(prefix)
    return subprocess.run([str(CLI), *map(str, args)], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=120)


def _printed_figures(stdout):
    """Return the report rows: name -> (final, predicted or None)."""
    figures = {}
    for line in stdout.splitlines():
        words = line.split()
        if line.startswith('  ') and words[0] not in ('converged', 'separation', 'quantity'):
            predicted = words[2] if len(words) > 2 else None
            figures[words[0]] = (words[1], predicted)
    return figures


def _params(npz):
    return json.loads(npz['params'].item())


@pytest.fixture(scope='module')
def particle_run(tmp_path_factory):
    cwd = tmp_path_factory.mktemp('particle')
    args = ['sim', CONFIG / 'particle_parallel.yaml', '--out', 'run.npz', '--plot', 'run.png',
            '--summary', 's.json', '--seed', '3']
    for override in PARTICLE_OVERRIDES:
        args += ['-p', override]
    proc = run_cli(cwd, *args)
    return cwd, proc


@pytest.fixture(scope='module')
def rigid_run(tmp_path_factory):
    cwd = tmp_path_factory.mktemp('rigid')
    proc = run_cli(cwd, 'sim', CONFIG / 'rigid_parallel.yaml', '--duration', '5', '--out',
                   'rigid.npz', '--plot', 'rigid.png', '-p', 'num_vehicles:=3', '-p',
                   'I0:=0.25', '-p', 'record_dt:=0.02')
    return cwd, proc


def test_console_script_is_installed():
    assert CLI.is_file() and os.access(CLI, os.X_OK)


def test_sim_exits_zero_and_prints_convergence_figures(particle_run):
    cwd, proc = particle_run
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ''
    lines = proc.stdout.splitlines()
    assert lines[0] == (f"{CONFIG / 'particle_parallel.yaml'}: 4 vehicles, second_order "
                        'parallel (backstepping), 5 s simulated offline')
    assert 'wrote run.npz' in lines and 'wrote run.png' in lines
    summary = json.loads((cwd / 's.json').read_text())
    assert set(summary) == SUMMARY_KEYS
    printed = _printed_figures(proc.stdout)
    assert {k: v[0] for k, v in printed.items()} == {
        k: f'{v:.6g}' for k, v in summary['final'].items()}
    assert {k: v[1] for k, v in printed.items() if v[1] is not None} == {
        k: f'{v:.6g}' for k, v in summary['predicted'].items()}
    assert summary['final']['order_parameter'] == summary['order_parameter']
    assert f"separation         {'kept apart' if summary['separation']['kept_apart'] else 'no'}" \
        in proc.stdout
    assert f"converged          {'yes' if summary['converged'] else 'no'}" in proc.stdout
    assert summary['num_vehicles'] == 4
    assert summary['duration'] == 5.0
    assert isinstance(summary['converged'], bool)
    assert summary['convergence_time'] is None or 0.0 <= summary['convergence_time'] <= 5.0
    assert summary['hold_window'] > 5.0 and not summary['converged']   # too short to hold it


def test_npz_has_the_documented_arrays(particle_run):
    cwd, _ = particle_run
    with np.load(cwd / 'run.npz', allow_pickle=False) as npz:
        assert set(npz.files) == {'t', 'params', 'meta', 'command', 'flow_hat_x', 'flow_hat_y',
                                  *STATE_KEYS}
        np.testing.assert_array_equal(npz['flow_hat_x'] + 1j * npz['flow_hat_y'], 0.2 + 0.1j)
        assert npz['command'].shape == (51, 4)
        t = npz['t']
        np.testing.assert_allclose(t, np.arange(51) * 0.1, atol=1e-9)
        for key in STATE_KEYS:
            assert npz[key].shape == (51, 4), key
            assert np.all(np.isfinite(npz[key])), key
        np.testing.assert_array_equal(npz['u'], 1.0)
        np.testing.assert_array_equal(npz['v'], 0.0)
        assert np.ptp(npz['theta']) > 0 and np.any(npz['omega'] != 0)


def test_npz_trajectories_move_at_unit_speed_through_the_flow(particle_run):
    cwd, _ = particle_run
    with np.load(cwd / 'run.npz', allow_pickle=False) as npz:
        r = npz['x'] + 1j * npz['y']
        speed = np.abs(np.diff(r, axis=0)) / np.diff(npz['t'])[:, None]
    flow = complex(0.2, 0.1)
    assert np.all(speed <= 1.0 + abs(flow) + 1e-6)
    assert np.all(speed >= 1.0 - abs(flow) - 1e-6)


def test_params_round_trip_and_reflect_overrides(particle_run):
    cwd, _ = particle_run
    with np.load(cwd / 'run.npz', allow_pickle=False) as npz:
        params, x0, y0 = _params(npz), npz['x'][0], npz['y'][0]
    expected = load(CONFIG / 'particle_parallel.yaml', PARTICLE_OVERRIDES, seed=3)
    assert params == expected.to_dict()
    assert resolve(params) == expected
    assert (params['num_vehicles'], params['duration'], params['flow'], params['kappa'],
            params['seed']) == (4, 5.0, [0.2, 0.1], 4.0, 3)
    assert (params['K'], params['model'], params['dt_control']) == (-1.0, 'second_order', 0.02)
    X0 = initial_state(expected)
    np.testing.assert_array_equal(x0, X0[0])
    np.testing.assert_array_equal(y0, X0[1])


def test_printed_order_parameter_matches_the_recorded_state(particle_run):
    cwd, _ = particle_run
    summary = json.loads((cwd / 's.json').read_text())
    with np.load(cwd / 'run.npz', allow_pickle=False) as npz:
        theta = npz['theta'][-1]
    gamma = np.angle(np.exp(1j * theta) + complex(0.2, 0.1))
    assert summary['order_parameter'] == pytest.approx(abs(np.exp(1j * gamma).mean()))


def test_plot_is_a_png(particle_run):
    cwd, _ = particle_run
    data = (cwd / 'run.png').read_bytes()
    assert data.startswith(b'\x89PNG\r\n\x1a\n')
    assert len(data) > 10_000
    width, height = struct.unpack('>II', data[16:24])
    assert width > height > 100


def test_rigid_npz_has_thrust_and_steering_force(rigid_run):
    cwd, proc = rigid_run
    assert proc.returncode == 0, proc.stderr
    assert 'rigid_parallel.yaml: 3 vehicles, rigid parallel (backstepping)' in proc.stdout
    figures = _printed_figures(proc.stdout)
    assert {'speed_error', 'crab_angle', 'crab_angle_inertial'} <= set(figures)
    with np.load(cwd / 'rigid.npz', allow_pickle=False) as npz:
        assert set(npz.files) == {'t', 'params', 'meta', 'T', 'F', 'flow_hat_x', 'flow_hat_y',
                                  *STATE_KEYS}
        arrays = {k: npz[k] for k in npz.files}
    params = json.loads(arrays['params'].item())
    assert (params['model'], params['num_vehicles'], params['duration'], params['I0']) == (
        'rigid', 3, 5.0, 0.25)
    for key in ('T', 'F', *STATE_KEYS):
        assert arrays[key].shape == (251, 3), key
        assert np.all(np.isfinite(arrays[key])), key
    run = simulator.load_run(cwd / 'rigid.npz')             # every period: T (7.1) is for the
    ctrl = Controller(run.sc)                               # state predicted to mid-hold
    for n in range(1, 251):
        X = ctrl.predict(run.X[n], run.U[n - 1])
        u, v, w = X[ROW_U], X[ROW_V], X[ROW_OMEGA]
        thrust = (params['h'] * np.hypot(u, v) * u - params['m0'] * v * w
                  + params['m0'] * params['K_f'] * (params['u0'] - u))
        np.testing.assert_allclose(run.U[n, 0], thrust, atol=1e-12)
    assert np.any(arrays['F'] != 0)
    assert np.all(arrays['u'] > 0)
    assert (cwd / 'rigid.png').read_bytes().startswith(b'\x89PNG\r\n\x1a\n')


def test_physics_note_is_printed_as_warning(rigid_run):
    _, proc = rigid_run
    assert proc.stderr.splitlines() == [
        'warning: right-half-plane zero u0*sqrt(h*l/I0) = 3.16 rad/s lies below the steering '
        'bandwidth 5 rad/s: expect slow, oscillating turns']


def test_bad_override_exits_2_naming_the_parameter(tmp_path):
    proc = run_cli(tmp_path, 'sim', CONFIG / 'particle_parallel.yaml', '--out', 'run.npz',
                   '-p', 'K:=1.0')
    assert proc.returncode == 2
    assert proc.stdout == ''
    assert proc.stderr.startswith("error: parameter 'K' = 1.0 is invalid: formation parallel "
                                  'needs K < 0')
    assert 'Traceback' not in proc.stderr
    assert not (tmp_path / 'run.npz').exists()


def test_out_of_memory_ends_with_one_line_naming_what_to_lower(tmp_path):
    limit = 1 << 30      # address space: the fleet's state alone needs 4.8 GB

    def cap():
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    env = dict(os.environ, MPLBACKEND='Agg', OPENBLAS_NUM_THREADS='1')
    proc = subprocess.run([str(CLI), 'sim', str(CONFIG / 'particle_circular.yaml'), '-p',
                           'num_vehicles:=100000000', '--duration', '1'], cwd=tmp_path,
                          env=env, capture_output=True, text=True, timeout=120, preexec_fn=cap)
    assert proc.returncode == 2
    lines = proc.stderr.splitlines()
    assert len(lines) == 1 and 'Traceback' not in proc.stderr
    assert lines[0].startswith('error: out of memory in sim: Unable to allocate')
    assert '(with num_vehicles:=100000000, --duration 1)' in lines[0]
    assert 'lower num_vehicles or --duration, or raise record_dt' in lines[0]


@pytest.mark.parametrize('command', ['sim', 'sweep'])
def test_a_memory_error_anywhere_in_main_is_one_line(monkeypatch, capsys, tmp_path, command):
    def exhausted(*args, **kwargs):
        raise MemoryError()

    monkeypatch.setattr(simulator.Stepper, 'command', exhausted)
    argv = [command, str(CONFIG / 'particle_parallel.yaml'), '-p', 'num_vehicles:=3']
    if command == 'sweep':
        argv += ['--seeds', '1', '--workers', '0', '--out', str(tmp_path / 'sweep.npz')]
    assert cli.main(argv) == (2 if command == 'sim' else 1)
    err = capsys.readouterr().err
    assert 'Traceback' not in err
    if command == 'sim':
        assert err == ('error: out of memory in sim: an allocation failed (with '
                       'num_vehicles:=3): lower num_vehicles or --duration, or raise '
                       'record_dt (fewer samples are kept)\n')
    else:
        assert ('error: batch 0 failed twice: grid point 0, seeds 0-0: out of memory (an '
                'allocation failed): lower --batch-size, num_vehicles or --duration\n') in err


def test_bad_parameter_file_exits_2(tmp_path):
    (tmp_path / 'bare.yaml').write_text('num_vehicles: 3\n')
    proc = run_cli(tmp_path, 'sim', 'bare.yaml')
    assert proc.returncode == 2
    assert proc.stderr.startswith('error: bare.yaml: a scenario is a ROS 2 parameter file')


@AMENT_CASES
def test_unknown_scenario_exits_2(tmp_path, ament):
    proc = run_cli(tmp_path, 'sim', 'no_such_scenario', ament=ament)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr == ("error: scenario 'no_such_scenario' not found "
                           '(a path, or one of config/*.yaml)\n')


@AMENT_CASES
def test_config_name_without_path_or_suffix_is_found(tmp_path, ament):
    proc = run_cli(tmp_path, 'sim', 'particle_parallel', '--duration', '1', '--summary',
                   's.json', '-p', 'num_vehicles:=2', '-p', 'duration:=50.0',
                   ament=ament)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith('particle_parallel: 2 vehicles, second_order parallel '
                                  '(backstepping), 1 s simulated offline')
    summary = json.loads((tmp_path / 's.json').read_text())
    assert (summary['num_vehicles'], summary['duration']) == (2, 1.0)


@pytest.mark.parametrize('command', ['report', 'plot'])
def test_plot_and_report_refuse_a_source_that_is_no_run(tmp_path, command):
    (tmp_path / 'notes.txt').write_text('not a run')
    for source in (tmp_path / 'missing', tmp_path / 'notes.txt', tmp_path):
        extra = ['--out', str(tmp_path / 'x.png')] if command == 'plot' else []
        proc = subprocess.run([str(CLI), command, str(source), *extra],
                              capture_output=True, text=True, timeout=60)
        assert proc.returncode == 2, proc.stderr
        assert str(source) in proc.stderr and 'error:' in proc.stderr
        assert 'pickle' not in proc.stderr and len(proc.stderr.splitlines()) == 1
    (tmp_path / 'run.json').write_text('{"converged": true}')
    told = subprocess.run([str(CLI), command, str(tmp_path / 'run.json'), *extra],
                          capture_output=True, text=True, timeout=60)
    assert told.stderr.strip() == (
        f'error: {tmp_path / "run.json"}: not a run .npz (no .npz archive); the run is the '
        '.npz of --out or a bag directory (a --summary .json is printed already)')


def test_report_of_an_npz_repeats_the_figures_of_the_run(particle_run):
    cwd, proc = particle_run
    again = subprocess.run([str(CLI), 'report', 'run.npz'], cwd=cwd,
                           capture_output=True, text=True, timeout=60)
    assert again.returncode == 0, again.stderr
    assert _printed_figures(again.stdout) == _printed_figures(proc.stdout)
