"""What Python can hand the binding cannot crash it, hang it or corrupt its results (issue 34).

- Every batch function over numpy layouts (data at byte offsets 0-7, views, negative strides, two
  ``np.frombuffer`` arrays over one buffer, sizes 0-17 and one past the streaming-store threshold) gives the
  single-call path's values bit for bit, or a one-line error for an ``out=`` it cannot use safely.
- A child process made by ``fork`` after its parent ran the thread pool computes instead of hanging (fork,
  spawn and forkserver).
- Ctrl-C (SIGINT) stops a long IK and a long batch within a second.
- IK budgets beyond their limits are one-line errors (no OverflowError).
"""

import multiprocessing as mp
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import denavit as dv

KR5 = dv.load_model("kr5")
PUMA = dv.load_model("puma560")  # with inertias: the dynamics batches
#: rows of batch FK whose output (128 B a row) passes the 8 MiB streaming-store threshold (stream.rs)
STREAMING_ROWS = 70_000


def unaligned(shape, offset, dtype=np.float64):
    """A C-contiguous, writeable array whose data starts `offset` bytes into an aligned buffer."""
    n = int(np.prod(shape))
    buf = bytearray(n * 8 + 16)
    base = np.frombuffer(buf, dtype=np.uint8)
    start = (-base.ctypes.data) % 16 + offset  # from a 16-byte boundary
    a = np.frombuffer(buf, dtype=dtype, count=n, offset=start).reshape(shape)
    assert a.flags.c_contiguous and a.flags.writeable and (a.ctypes.data % 8 == 0) == (offset % 8 == 0)
    return a


def configurations(n, nq=6, seed=0):
    return np.random.default_rng(seed).uniform(-2.0, 2.0, (n, nq))


# the batch functions: (model, number of (N, n) inputs, the values row by row from the single calls)
BATCHES = {
    "fk_batch": (KR5, 1, lambda m, q: np.array([dv.fk(m, x) for x in q])),
    "jacobian_batch": (KR5, 1, lambda m, q: np.array([dv.jacobian(m, x) for x in q])),
    "rnea_batch": (PUMA, 3, lambda m, q, qd, qdd: np.array([dv.rnea(m, a, b, c) for a, b, c in zip(q, qd, qdd)])),
    "bias_forces_batch": (PUMA, 2, lambda m, q, qd: np.array([dv.bias_forces(m, a, b) for a, b in zip(q, qd)])),
    "gravity_torques_batch": (PUMA, 1, lambda m, q: np.array([dv.gravity_torques(m, a) for a in q])),
    "mass_matrix_batch": (PUMA, 1, lambda m, q: np.array([dv.mass_matrix(m, a) for a in q])),
    "coriolis_matrix_batch": (PUMA, 2, lambda m, q, qd: np.array([dv.coriolis_matrix(m, a, b) for a, b in zip(q, qd)])),
    "forward_dynamics_batch": (
        PUMA,
        3,
        lambda m, q, qd, tau: np.array([dv.forward_dynamics(m, a, b, c) for a, b, c in zip(q, qd, tau)]),
    ),
}


def out_shape(name, m, n):
    return {
        "fk_batch": (n, 4, 4),
        "jacobian_batch": (n, 6, m.nq),
        "mass_matrix_batch": (n, m.nq, m.nq),
        "coriolis_matrix_batch": (n, m.nq, m.nq),
    }.get(name, (n, m.nq))


#: batches whose kernels are the single calls' arithmetic (bit for bit); the dynamics batches reorder sums
#: (vectorised over rows), so they are compared with the single calls to rounding and with themselves
#: (the plain aligned layout) bit for bit
BIT_FOR_BIT = {"fk_batch", "jacobian_batch"}


def expected(name, m, inputs):
    """The batch's values for `inputs`: from the single calls, bit for bit where the kernels are the same."""
    ref = BATCHES[name][2](m, *inputs).reshape(out_shape(name, m, len(inputs[0])))
    if name in BIT_FOR_BIT:
        return ref
    plain = getattr(dv, name)(m, *[np.ascontiguousarray(x) for x in inputs])
    np.testing.assert_allclose(plain, ref, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(ref).max()))
    return plain


@pytest.mark.parametrize("name", sorted(BATCHES))
@pytest.mark.parametrize("n", [0, 1, 2, 3, 7, 8, 9, 16, 17])
def test_every_input_offset_and_layout_gives_the_single_calls_values(name, n):
    m, k, _ = BATCHES[name]
    fn = getattr(dv, name)
    inputs = [configurations(n, m.nq, seed=s) for s in range(k)]
    want = expected(name, m, inputs) if n else np.zeros(out_shape(name, m, 0))
    for offset in range(8):
        moved = []
        for x in inputs:
            u = unaligned(x.shape, offset)
            u[...] = x
            moved.append(u)
        got = fn(m, *moved)
        np.testing.assert_array_equal(got, want, err_msg=f"{name}, inputs at byte offset {offset}")
    # negative strides, every other row, Fortran order: converted, same values
    for view in (lambda x: x[::-1].copy()[::-1], lambda x: np.repeat(x, 2, axis=0)[::2], np.asfortranarray):
        np.testing.assert_array_equal(fn(m, *[view(x) for x in inputs]), want)


@pytest.mark.parametrize("name", sorted(BATCHES))
def test_out_at_every_offset_is_filled_exactly_or_refused(name):
    m, k, _ = BATCHES[name]
    fn = getattr(dv, name)
    inputs = [configurations(17, m.nq, seed=s) for s in range(k)]
    want = expected(name, m, inputs)
    for offset in range(8):
        out = unaligned(want.shape, offset)
        if offset % 8 == 0:
            assert fn(m, *inputs, out=out) is out
            np.testing.assert_array_equal(out, want)
        else:
            with pytest.raises(
                dv.DenavitError,
                match=(
                    r"^invalid out: expected a C-contiguous, writeable float64 numpy array of shape .* whose data is"
                    r" 8-byte aligned, got an array whose data starts at an address not a multiple of 8"
                ),
            ):
                fn(m, *inputs, out=out)


@pytest.mark.parametrize("name", ["fk_batch", "jacobian_batch"])
def test_unaligned_out_past_the_streaming_threshold_is_refused_not_a_crash(name):
    # the segfault of issue 34: streaming stores (movntpd / vmovntpd) to an address that is not aligned
    qs = configurations(STREAMING_ROWS)
    shape = out_shape(name, KR5, STREAMING_ROWS)
    for offset in (1, 4, 7):
        with pytest.raises(dv.DenavitError, match="not a multiple of 8"):
            getattr(dv, name)(KR5, qs, out=unaligned(shape, offset))
    # aligned at 8 (not 16) and 16: streamed or not, the values of the single path
    ref = getattr(dv, name)(KR5, qs, threads=1)
    np.testing.assert_array_equal(ref[:50], expected(name, KR5, [qs[:50]]))
    for offset in (0, 8):
        out = unaligned(shape, offset)
        getattr(dv, name)(KR5, qs, out=out)
        np.testing.assert_array_equal(out, ref)


def test_unaligned_single_calls_read_the_right_values():
    q = configurations(1)[0]
    for offset in range(1, 8):
        u = unaligned((6,), offset)
        u[:] = q
        np.testing.assert_array_equal(dv.fk(KR5, u), dv.fk(KR5, q))
        np.testing.assert_array_equal(dv.jacobian(KR5, u), dv.jacobian(KR5, q))
        T = unaligned((4, 4), offset)
        T[...] = dv.fk(KR5, q)
        assert dv.ik(KR5, T, q + 0.01).success
    # strided 1-D views (a stride of 12 bytes: elements at unaligned addresses)
    raw = np.zeros(6 * 12 + 8, dtype=np.uint8)
    s = np.lib.stride_tricks.as_strided(raw[4:].view(np.uint8), shape=(6,), strides=(12,))
    assert s.dtype == np.uint8  # not float: converted by numpy
    f = np.lib.stride_tricks.as_strided(np.frombuffer(raw.data, dtype=np.float64, count=9), shape=(6,), strides=(12,))
    assert not f.flags.aligned
    np.testing.assert_array_equal(dv.fk(KR5, f), dv.fk(KR5, np.array(f)))


def test_out_sharing_memory_with_an_input_through_frombuffer_is_refused():
    n = 40
    buf = bytearray(n * 16 * 8)
    qs = np.frombuffer(buf, dtype=np.float64, count=n * 6)
    qs[:] = configurations(n).ravel()
    qs = qs.reshape(n, 6)
    out = np.frombuffer(buf, dtype=np.float64).reshape(n, 4, 4)  # the same bytes, another array object
    assert not np.shares_memory(qs, np.zeros(1)) and np.shares_memory(qs, out)
    before = bytes(buf)
    with pytest.raises(dv.DenavitError, match="^invalid out: .*sharing no memory with qs.*overlaps qs"):
        dv.fk_batch(KR5, qs, out=out)
    assert bytes(buf) == before  # nothing written
    # disjoint halves of one buffer are fine
    big = bytearray(n * 6 * 8 + n * 16 * 8)
    a = np.frombuffer(big, dtype=np.float64, count=n * 6).reshape(n, 6)
    a[...] = configurations(n)
    b = np.frombuffer(big, dtype=np.float64, offset=n * 6 * 8).reshape(n, 4, 4)
    dv.fk_batch(KR5, a, out=b)
    np.testing.assert_array_equal(b, dv.fk_batch(KR5, configurations(n)))
    # the dynamics batches check each input
    qd = np.frombuffer(buf, dtype=np.float64, count=n * 6).reshape(n, 6)
    with pytest.raises(dv.DenavitError, match="overlaps qds"):
        dv.rnea_batch(
            PUMA,
            configurations(n),
            qd,
            configurations(n),
            out=np.frombuffer(buf, dtype=np.float64, count=n * 6).reshape(n, 6),
        )


def test_datetime_and_timedelta_arrays_are_not_joint_values():
    for a in (np.array(["2026-01-01"] * 6, dtype="datetime64[D]"), np.arange(6).astype("timedelta64[s]")):
        with pytest.raises(
            dv.DenavitError, match="^invalid q: expected an array-like of real floats, got a (datetime|timedelta) array"
        ):
            dv.fk(KR5, a)


def test_ik_budgets_beyond_their_limits_are_one_line_errors():
    T = dv.fk(KR5, np.full(6, 0.3))
    for kw, match in [
        ({"restarts": 10**18}, r"^invalid restarts: expected at most 1000000, got 1000000000000000000$"),
        ({"max_iterations": 2**63}, r"^invalid max_iterations: expected at most 1000000, got 9223372036854775808$"),
        (
            {"max_iterations": 10**6 + 1},
            r"^invalid max_iterations: expected at most 1000000 \(per attempt\), got 1000001$",
        ),
        ({"max_iterations": 0}, "max_iterations"),
        ({"restarts": -1}, "restarts: expected an integer >= 0"),
        ({"restarts": -(2**70)}, "restarts: expected an integer >= 0"),
        ({"seed": 2**70}, "seed: expected at most 9223372036854775807"),
    ]:
        with pytest.raises(dv.DenavitError, match=match):
            dv.ik(KR5, T, **kw)
        with pytest.raises(dv.DenavitError, match=match):
            dv.ik_batch(KR5, T[None], **kw)
    assert dv.ik(KR5, T, np.full(6, 0.2), restarts=10**6, max_iterations=10**6).success  # at the limits: runs


# --- fork -------------------------------------------------------------------------------------------------


def _child_fk(q):
    # the default threads: the pool of this process
    return dv.fk_batch(KR5, q)


@pytest.mark.parametrize("method", ["fork", "spawn", "forkserver"])
def test_a_child_process_computes_after_the_parent_ran_the_pool(method):
    if method not in mp.get_all_start_methods():
        pytest.skip(f"no {method} start method here")
    qs = configurations(20_000)  # several chunks: the pool starts
    want = dv.fk_batch(KR5, qs)
    dv.fk_batch(KR5, qs, threads=2)
    ctx = mp.get_context(method)
    with ctx.Pool(1) as pool:
        r = pool.apply_async(_child_fk, (qs,))
        got = r.get(timeout=60)  # hung forever before the fix
    np.testing.assert_array_equal(got, want)


# --- Ctrl-C -----------------------------------------------------------------------------------------------

LONG_CALLS = {
    "ik": (
        "dv.ik(m, np.array([[1, 0, 0, 5.0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]), restarts=10**6,"
        " max_iterations=10**6)"
    ),
    "ik_batch": (
        "dv.ik_batch(m, np.repeat(np.array([[[1, 0, 0, 5.0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]]), 4, 0),"
        " restarts=10**6)"
    ),
    "forward_dynamics_batch": "q = np.zeros((3_000_000, 6)); dv.forward_dynamics_batch(p, q, q, q, threads=1)",
}


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
@pytest.mark.parametrize("call", sorted(LONG_CALLS))
def test_ctrl_c_stops_a_long_call_within_a_second(call):
    code = (
        "import numpy as np, sys, denavit as dv\n"
        "m = dv.load_model('kr5'); p = dv.load_model('puma560')\n"
        "print('ready', flush=True)\n"
        f"{LONG_CALLS[call]}\n"
        "print('finished', flush=True)\n"
    )
    with subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    ) as proc:
        try:
            assert proc.stdout.readline().strip() == "ready"
            time.sleep(0.5)  # inside the call (each runs for tens of seconds or more)
            assert proc.poll() is None, proc.communicate()
            t0 = time.monotonic()
            proc.send_signal(signal.SIGINT)
            _, err = proc.communicate(timeout=10)
            took = time.monotonic() - t0
            rc = proc.returncode
        finally:
            if proc.poll() is None:
                proc.kill()
    assert rc != 0 and "KeyboardInterrupt" in err, (rc, err)
    assert took < 1.0, f"{call}: {took:.2f} s after SIGINT"


def test_after_an_interrupt_calls_run_again():
    code = (
        "import numpy as np, signal, threading, os, denavit as dv\nm = dv.load_model('kr5')\nT = np.array([[1, 0, 0,"
        " 5.0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])\nthreading.Timer(0.3, lambda: os.kill(os.getpid(),"
        " signal.SIGINT)).start()\ntry:\n    dv.ik(m, T, restarts=10**6)\nexcept KeyboardInterrupt:\n   "
        " print('interrupted')\nq = np.full(6, 0.3)\nprint(dv.ik(m, dv.fk(m, q), q + 0.01).success,"
        " np.array_equal(dv.fk_batch(m, np.tile(q, (300000, 1)))[-1], dv.fk(m, q)))\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.stdout.split() == ["interrupted", "True", "True"], r.stderr


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_ctrl_c_ends_a_long_cli_command_with_exit_130():
    cmd = [sys.executable, "-m", "denavit.cli", "ik", "kr5", "--pose", "5000,0,0,0,0,0", "--restarts", "1000000"]
    with subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as proc:
        try:
            time.sleep(2.0)  # imports, then the solve (about 100 s of restarts)
            assert proc.poll() is None, proc.communicate()
            t0 = time.monotonic()
            proc.send_signal(signal.SIGINT)
            _, err = proc.communicate(timeout=10)
            took = time.monotonic() - t0
        finally:
            if proc.poll() is None:
                proc.kill()
    assert proc.returncode == 130 and err.strip() == "interrupted", (proc.returncode, err)
    assert took < 1.0
