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

"""tools/bench_compare.py: the ratios it prints and the regressions it flags."""
import importlib.util
from pathlib import Path

SPEC = importlib.util.spec_from_file_location(
    'bench_compare', Path(__file__).resolve().parents[2] / 'tools' / 'bench_compare.py')
bench_compare = importlib.util.module_from_spec(SPEC)
SPEC.loader.exec_module(bench_compare)


def test_a_ratio_over_the_threshold_is_a_regression_and_new_or_gone_ones_are_named(capsys):
    base = {'fast': 1.0, 'slow': 1.0, 'edge': 1.0, 'gone': 2.0}
    now = {'fast': 0.5, 'slow': 1.25, 'edge': 1.2, 'new': 3.0}
    assert bench_compare.report(base, now, 0.2) == ['slow']
    rows = {line.split()[0]: line.split() for line in capsys.readouterr().out.splitlines()[2:]}
    assert rows['fast'][-1] == '0.50'
    assert rows['slow'][-2:] == ['1.25', 'REGRESSION']
    assert rows['edge'][-1] == '1.20'
    assert rows['new'][-1] == 'new' and rows['gone'][-1] == 'gone'


def test_the_figure_of_a_benchmark_is_the_median_of_the_runs_that_have_it():
    runs = [{'a': 1.0, 'b': 5.0}, {'a': 3.0}, {'a': 2.0, 'b': 7.0}]
    assert bench_compare._medians(runs) == {'a': 2.0, 'b': 6.0}
