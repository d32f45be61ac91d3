"""`exit_on_user_error`: the one way out of every command-line tool."""

import pytest

from litl.errors import UserError, exit_on_user_error


def test_a_user_error_is_one_line_and_exit_status_2(capsys):
    with pytest.raises(SystemExit) as exit_info, exit_on_user_error("python -m litl.report"):
        raise UserError("no runs found in x; give a run directory")
    assert exit_info.value.code == 2
    assert (
        capsys.readouterr().err == "python -m litl.report: error: no runs found in x; give a run directory\n"
    )


def test_lines_go_where_the_command_says():
    lines = []
    with pytest.raises(SystemExit), exit_on_user_error("litl", write=lines.append):
        raise UserError("seeds=0: must be a positive integer")
    assert lines == ["litl: error: seeds=0: must be a positive integer"]


def test_os_errors_are_the_users_only_where_the_command_says_so(capsys):
    with pytest.raises(FileNotFoundError), exit_on_user_error("litl.replay"):
        raise FileNotFoundError("nowhere")
    with pytest.raises(SystemExit) as exit_info, exit_on_user_error("python -m litl.claims", os_errors=True):
        raise PermissionError("[Errno 13] Permission denied: 'out'")
    assert exit_info.value.code == 2
    assert capsys.readouterr().err == "python -m litl.claims: error: [Errno 13] Permission denied: 'out'\n"


def test_bugs_and_a_kept_traceback_pass_through(capsys):
    with pytest.raises(KeyError), exit_on_user_error("litl"):
        raise KeyError("a bug")
    with pytest.raises(UserError, match="kept"), exit_on_user_error("litl", keep_traceback=True):
        raise UserError("kept")
    assert capsys.readouterr().err == ""
