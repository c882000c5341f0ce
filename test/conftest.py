from pathlib import Path

import pytest

CONFIG = Path(__file__).resolve().parents[1] / 'config'


@pytest.fixture
def config_dir():
    return CONFIG
