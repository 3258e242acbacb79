"""Every float option of every command refuses NaN and infinities before any work: exit 2, one sentence naming the
option, nothing written. The options are found by walking the command group, so a new one cannot escape."""

import click
import pytest
from click.testing import CliRunner
from sumo_rail_cli.main import cli


def float_options() -> list[tuple[str, str]]:
    """(command, option) for every option of a float type, hidden ones too."""
    found = []
    for name, command in sorted(cli.commands.items()):
        for param in command.params:
            if isinstance(param, click.Option) and isinstance(param.type, click.types.FloatParamType):
                found += [(name, max(param.opts, key=len))]
    return found


def test_the_walk_finds_the_float_options_the_issue_names():
    assert {("record-expert", "--dart-noise"), ("train", "--step-size"), ("train", "--bc-class-balance"),
            ("gail", "--learning-rate")} <= set(float_options())


@pytest.mark.parametrize(("command", "option"), float_options(), ids=lambda part: part)
@pytest.mark.parametrize("value", ["nan", "inf", "-inf"])
def test_a_float_option_refuses_what_is_no_number(tmp_path, monkeypatch, command, option, value):
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(cli, [command, f"{option}={value}", "--out", "out"])
    assert result.exit_code == 2, result.output
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert errors == [f"Error: Invalid value for '{option}': {value} is not a finite number."], result.output
    assert "Traceback" not in result.output
    assert list(tmp_path.iterdir()) == []
