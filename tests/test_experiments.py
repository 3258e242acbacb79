import subprocess
from pathlib import Path

import pytest

SCRIPTS = sorted((Path(__file__).parent.parent / "experiments").glob("*.sh"))


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda path: path.name)
def test_experiment_scripts_parse_and_are_executable(script: Path):
    assert subprocess.run(["bash", "-n", str(script)], capture_output=True, text=True).returncode == 0
    assert script.stat().st_mode & 0o111


def test_every_documented_experiment_exists():
    assert {path.name for path in SCRIPTS} >= {"demo.sh", "imitation_table.sh", "directions_sweep.sh",
                                               "style_fidelity.sh"}
