import subprocess
import sys

from mnss_kit import cli


def test_help_lists_every_present_subcommand(capsys):
    parser = cli.build_parser()
    help_text = parser.format_help()
    for name in cli.available_commands():
        assert name in help_text


def test_help_runs_as_a_console_script():
    out = subprocess.run([sys.executable, "-m", "mnss_kit", "--help"], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0
    assert "COMMAND" in out.stdout


def test_user_error_is_one_line_and_exit_2(capsys, tmp_path):
    if "data" not in cli.available_commands():
        return
    code = cli.main(["data", "check", str(tmp_path / "does-not-exist")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code != 0
    assert len(err) == 1 and "error" in err[0]


def test_every_listed_command_module_exists():
    assert cli.available_commands() == cli.COMMANDS
