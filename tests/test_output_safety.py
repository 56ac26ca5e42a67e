"""Outputs keep what the user had (issue 34, item 8; docs/cli.md, "How outputs are written"): the owner and mode of
a replaced file, a read-only file and hard links (refused without --force / force=True), no temporary file left
by SIGTERM or, after SIGKILL, by the next write, a closed standard output as an error, accurate messages for
targets that are not regular files, and input files never modified."""

import os
import signal
import stat
import subprocess
import sys
import textwrap
import time

import pytest
from typer.testing import CliRunner

import denavit as dv
from cli import env, error_line
from denavit.cli.common import app
from denavit.io import output

root_only = pytest.mark.skipif(os.geteuid() != 0, reason="giving a file to another user needs root")


def cli(*args):
    """``denavit ARGS`` in this process: (exit code, the error's one line or None)."""
    r = CliRunner().invoke(app, [str(a) for a in args])
    if isinstance(r.exception, dv.DenavitError):
        return 2, str(r.exception)
    assert r.exception is None or isinstance(r.exception, SystemExit), r.exception
    return r.exit_code, None


def debris(folder):
    """The hidden files left in ``folder`` (temporary files, probes)."""
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


# -- owner and mode ---------------------------------------------------------------------------------------------


@root_only
def test_another_users_file_keeps_its_owner_and_mode(tmp_path):
    f = tmp_path / "theirs.toml"
    f.write_text("old")
    os.chown(f, 65534, 65534)
    f.chmod(0o640)
    output.write_text(f, "new")
    st = f.stat()
    assert (st.st_uid, st.st_gid, stat.S_IMODE(st.st_mode)) == (65534, 65534, 0o640) and f.read_text() == "new"
    # through the command line as well
    assert cli("convert", "kr5", "--to", "mdh", "-o", f) == (0, None)
    st = f.stat()
    assert (st.st_uid, st.st_gid, stat.S_IMODE(st.st_mode)) == (
        65534,
        65534,
        0o640,
    ) and 'convention = "mdh"' in f.read_text()
    assert debris(tmp_path) == []


def test_an_owner_that_cannot_be_kept_is_refused_not_taken_over(tmp_path, monkeypatch):
    """As a user who may not give files away (fchown: EPERM), another user's file is not replaced by one of
    this user's: one line, the old file intact, no debris."""
    f = tmp_path / "theirs.toml"
    f.write_text("old")
    st = f.stat()
    fake = os.stat_result((st.st_mode, st.st_ino, st.st_dev, st.st_nlink, 4242, 4242, *tuple(st)[6:]))

    def refuse(*_a):
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr(output.os, "fchown", refuse)
    real_target = output._target
    monkeypatch.setattr(
        output, "_target", lambda p: (lambda t: (t[0], t[1], fake if t[2] is not None else None))(real_target(p))
    )
    with pytest.raises(dv.DenavitError, match=r"theirs.toml: cannot keep its owner \(uid 4242, gid 4242\)") as e:
        output.write_text(f, "new")
    assert "\n" not in str(e.value) and f.read_text() == "old" and debris(tmp_path) == []
    with pytest.raises(dv.DenavitError, match="cannot keep its owner"):
        output.check_writable(f)  # the command line's check before the work starts says the same


def test_a_new_file_gets_the_umask_and_a_replaced_one_its_set_id_bits(tmp_path):
    old = os.umask(0o027)
    try:
        new = tmp_path / "new.toml"
        output.write_text(new, "x")
        assert stat.S_IMODE(new.stat().st_mode) == 0o640
        f = tmp_path / "sgid.toml"
        f.write_text("old")
        f.chmod(0o2750)
        output.write_text(f, "new")
        assert stat.S_IMODE(f.stat().st_mode) == 0o2750
    finally:
        os.umask(old)


# -- read-only files -----------------------------------------------------------------------------------------


def test_a_read_only_file_is_refused_without_force_and_replaced_with_it(tmp_path):
    f = tmp_path / "ro.toml"
    f.write_text("old")
    f.chmod(0o444)
    with pytest.raises(dv.DenavitError, match=r"ro.toml: is read-only \(mode 0444\): not replaced; give --force") as e:
        output.write_text(f, "new")
    assert "\n" not in str(e.value) and f.read_text() == "old"
    output.write_text(f, "new", force=True)
    assert f.read_text() == "new" and stat.S_IMODE(f.stat().st_mode) == 0o444
    assert debris(tmp_path) == []


def test_a_read_only_file_through_the_command_line(tmp_path):
    f = tmp_path / "ro.toml"
    f.write_text("old")
    f.chmod(0o444)
    code, err = cli("convert", "kr5", "--to", "mdh", "-o", f)
    assert code == 2 and "is read-only (mode 0444)" in err and "--force" in err and f.read_text() == "old"
    code, err = cli("fk", "kr5", "--json", f)
    assert code == 2 and "is read-only" in err and f.read_text() == "old"
    assert cli("convert", "kr5", "--to", "mdh", "-o", f, "--force") == (0, None)
    assert 'convention = "mdh"' in f.read_text() and stat.S_IMODE(f.stat().st_mode) == 0o444


def test_every_command_that_writes_takes_force_and_only_those():
    from denavit.cli.common import COMMANDS, OUTPUT_OPTIONS, build_command

    forced = set()
    for name in COMMANDS:
        opts = {o for p in build_command(name).params for o in p.opts}
        writes = bool(opts & (OUTPUT_OPTIONS | {"--plot"}))
        assert ("--force" in opts) == writes, name
        forced |= {name} if writes else set()
    assert {
        "convert",
        "simulate",
        "identify",
        "calibrate",
        "compensate",
        "show",
        "export",
        "fk",
    } <= forced and "inspect" not in forced


# -- hard links ----------------------------------------------------------------------------------------------


def test_a_hard_link_is_refused_naming_the_count_and_written_through_with_force(tmp_path):
    f, g = tmp_path / "a.toml", tmp_path / "b.toml"
    f.write_text("old")
    os.link(f, g)
    with pytest.raises(dv.DenavitError, match=r"a.toml: has 2 hard links: replacing it would split them.*--force") as e:
        output.write_text(f, "new")
    assert "\n" not in str(e.value) and f.read_text() == g.read_text() == "old"
    output.write_text(f, "newer and longer", force=True)
    output.write_text(f, "short", force=True)  # truncated, not the tail of the longer one
    assert f.read_text() == g.read_text() == "short"
    assert f.stat().st_ino == g.stat().st_ino and f.stat().st_nlink == 2 and debris(tmp_path) == []
    code, err = cli("convert", "kr5", "--to", "mdh", "-o", g)
    assert code == 2 and "has 2 hard links" in err and g.read_text() == "short"
    assert cli("convert", "kr5", "--to", "mdh", "-o", g, "--force") == (0, None)
    assert 'convention = "mdh"' in f.read_text() and f.stat().st_ino == g.stat().st_ino


def test_an_input_is_never_modified_even_through_a_hard_link_with_force(tmp_path):
    from denavit.io import robotfile

    src = tmp_path / "in.toml"
    robotfile.save(dv.load_robot("kr5"), src)
    before = src.read_bytes()
    link = tmp_path / "link.toml"
    os.link(src, link)
    code, err = cli("convert", src, "--to", "mdh", "-o", link, "--force")
    assert code == 2 and "an output never replaces an input" in err and src.read_bytes() == before


# -- temporary files -----------------------------------------------------------------------------------------

WRITER = textwrap.dedent("""
    import sys, time
    from denavit.io import output
    with output.atomic_path(sys.argv[1]) as tmp:
        with open(tmp, "wb") as f:
            print(tmp, flush=True)
            while True:  # a large write, 1 MB at a time
                f.write(b"x" * 2**20)
                f.flush()
                time.sleep(0.01)
""")


def _start_writer(target):
    p = subprocess.Popen([sys.executable, "-c", WRITER, str(target)], stdout=subprocess.PIPE, text=True, env=env())
    tmp = p.stdout.readline().strip()
    p.stdout.close()
    assert tmp and os.path.basename(tmp).startswith(f".{target.name}.dv{p.pid}."), tmp
    deadline = time.monotonic() + 5
    while os.path.getsize(tmp) < 2**21 and time.monotonic() < deadline:
        time.sleep(0.01)
    return p, tmp


def test_sigterm_during_a_large_write_leaves_no_temporary_file(tmp_path):
    target = tmp_path / "big.csv"
    target.write_text("old\n")
    p, tmp = _start_writer(target)
    p.send_signal(signal.SIGTERM)
    assert p.wait(10) == -signal.SIGTERM  # ended by the signal, as before
    assert not os.path.exists(tmp) and target.read_text() == "old\n" and debris(tmp_path) == []


def test_a_temporary_file_left_by_sigkill_is_cleaned_by_the_next_write(tmp_path):
    target = tmp_path / "big.csv"
    target.write_text("old\n")
    p, tmp = _start_writer(target)
    p.kill()
    p.wait(10)
    assert os.path.exists(tmp) and target.read_text() == "old\n"
    past = time.time() - 2 * output.STALE_SECONDS
    os.utime(tmp, (past, past))
    # not removed: a live writer's (this process), a fresh one of a dead writer, other names, another output's
    live = tmp_path / f".big.csv.dv{os.getpid()}.abcdefgh.csv"
    fresh = tmp_path / f".big.csv.dv{p.pid}.freshone.csv"
    others = [
        tmp_path / ".big.csv.backup",
        tmp_path / f".big.csv.dv{p.pid}.short.csv",
        tmp_path / f".other.csv.dv{p.pid}.abcdefgh.csv",
    ]
    for f in (live, fresh, *others):
        f.write_text("keep")
        if f is not fresh:
            os.utime(f, (past, past))
    output.write_text(target, "new\n")
    assert target.read_text() == "new\n" and not os.path.exists(tmp)
    assert all(f.exists() for f in (live, fresh, *others))
    abandoned = past - output.ABANDONED_SECONDS
    os.utime(live, (abandoned, abandoned))  # a pid reused since: an hour without change is enough
    output.write_text(target, "newer\n")
    assert not live.exists() and fresh.exists()


def test_the_signal_handlers_are_installed_during_a_write_only():
    before = signal.getsignal(signal.SIGTERM)
    with output.atomic_path(os.devnull) as tmp:
        assert signal.getsignal(signal.SIGTERM) is output._on_signal and str(tmp) in output._active
    assert signal.getsignal(signal.SIGTERM) is before and not output._active


def test_a_programs_own_sigterm_handler_is_called_and_the_write_left_clean(tmp_path):
    """A program that handles SIGTERM itself keeps its handler: called during a write, its exception ends the
    write (old file kept, no debris), and it is in place again after."""

    class Stop(Exception):
        pass

    def handler(*_a):
        raise Stop

    old = signal.signal(signal.SIGTERM, handler)
    try:
        f = tmp_path / "out.txt"
        f.write_text("old")
        with pytest.raises(Stop), output.atomic_path(f) as tmp:
            tmp.write_text("half")
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(1)
        assert f.read_text() == "old" and debris(tmp_path) == [] and signal.getsignal(signal.SIGTERM) is handler
    finally:
        signal.signal(signal.SIGTERM, old)


# -- standard output -----------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "args", [("show", "kr5"), ("fk", "kr5", "--json", "-"), ("convert", "kr5", "--to", "mdh", "-o", "-")]
)
def test_a_closed_standard_output_is_exit_2(args):
    p = subprocess.run(
        [sys.executable, "-m", "denavit.cli", *args],
        stdout=None,
        stderr=subprocess.PIPE,
        text=True,
        env=env(),
        preexec_fn=lambda: os.close(1),
    )  # noqa: PLW1509 (the child's fd 1 closed: `>&-`)
    line = error_line(p.stderr)
    assert p.returncode == 2 and line is not None and "standard output" in line and "closed" in line, p.stderr


def test_writing_to_a_closed_standard_output_in_python_is_an_error(monkeypatch):
    monkeypatch.setattr(sys, "stdout", output.ClosedStdout())
    with pytest.raises(dv.DenavitError, match="standard output: cannot write: it is closed"):
        output.write_text("-", "x")


# -- what is not a regular file ------------------------------------------------------------------------------


def test_a_symlink_into_proc_is_named_as_such(tmp_path):
    link = tmp_path / "status"
    link.symlink_to("/proc/self/status")
    with pytest.raises(
        dv.DenavitError,
        match=(
            r"status: cannot write the output: /proc/\d+/status is a file of the kernel's proc filesystem, not a"
            r" regular file"
        ),
    ):
        output.write_text(link, "x")
    link2 = tmp_path / "new"
    link2.symlink_to("/proc/self/no_such_file")
    with pytest.raises(
        dv.DenavitError, match=r"new: cannot write: its directory /proc/\d+ is on the kernel's proc filesystem"
    ) as e:
        output.write_text(link2, "x")
    assert "does not exist" not in str(e.value)
    code, err = cli("convert", "kr5", "--to", "mdh", "-o", link)
    assert code == 2 and "kernel's proc filesystem" in err


def test_a_directory_that_is_a_file_is_named_as_such(tmp_path):
    f = tmp_path / "file.txt"
    f.write_text("x")
    with pytest.raises(dv.DenavitError, match=r"file.txt/out.toml: cannot write: .*file.txt is not a directory"):
        output.write_text(f / "out.toml", "x")
    assert f.read_text() == "x"
