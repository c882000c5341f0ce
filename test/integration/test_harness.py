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

"""The harness keeps tests apart: a process a test leaves running fails it and is killed."""
import os
import subprocess
import sys

import pytest
import rosutil


def test_a_process_left_running_in_a_test_domain_fails_the_test_and_is_killed(monkeypatch):
    monkeypatch.setattr(rosutil.reap, '__defaults__', (0.5,))
    outside = subprocess.Popen([sys.executable, '-c', 'import time; time.sleep(60)'])
    with pytest.raises(AssertionError, match='processes outlived their test') as failed:
        with rosutil.domains() as (did,):
            left = subprocess.Popen([sys.executable, '-c', 'import time; time.sleep(60)'],
                                    env=rosutil.ros_environment(did))
    assert str(left.pid) in str(failed.value)
    assert left.wait(timeout=10) == -9
    assert outside.poll() is None                        # not the test's: left alone
    outside.kill()
    outside.wait()
    assert rosutil.MARK_ENV not in os.environ
