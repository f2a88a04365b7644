"""Compile once, for every command: a second process running the same command on the same drive loads every
program from the persistent compilation cache and compiles nothing new, without any environment variable
(``EQX_ON_ERROR`` is removed from the children's environment on purpose).

Every command runs in a subprocess under a small wrapper that counts, per command, JAX's persistent-cache events
(``/jax/compilation_cache/compile_requests_use_cache`` and ``.../cache_hits``), every backend compilation
(hit or not) and the names of the programs that missed; all the commands one after another in one process,
then all again in a second one. The commands share one cache directory (a temporary one for this file): in
the second process every command must hit for every program it asks for. One tiny drive (Benchmark A's
geometry, 12 elements, 0.02 s: a transient) keeps the compiles short.
"""

import contextlib
import json
import os
import subprocess
import sys
import textwrap
import threading

import numpy as np
import pytest
from helpers import two_pulley_toml

from jaxbelt.cli.compile_notice import NOTICE, CompileNotice

COUNTER = textwrap.dedent('''
    """The jaxbelt CLI (argv) under a counter of persistent-cache requests, hits and missed programs."""
    import json, logging, os, sys

    from jax import monitoring

    counts = {"requests": 0, "hits": 0, "compiles": 0, "missed": [], "traced": 0}

    import jax.export as _jex

    _export = _jex.export


    def _counted_export(*a, **kw):  # jaxbelt._export traces a program it did not find stored
        counts["traced"] += 1
        return _export(*a, **kw)


    _jex.export = _counted_export


    def _event(name, **kw):
        if name == "/jax/compilation_cache/compile_requests_use_cache":
            counts["requests"] += 1
        elif name == "/jax/compilation_cache/cache_hits":
            counts["hits"] += 1


    def _duration(name, secs, **kw):
        if name == "/jax/core/compile/backend_compile_duration":  # every XLA compile (or cache load)
            counts["compiles"] += 1


    class _Missed(logging.Handler):
        def emit(self, record):
            if record.getMessage().startswith("PERSISTENT COMPILATION CACHE MISS"):
                counts["missed"].append(str(record.args[0]))


    monitoring.register_event_listener(_event)
    monitoring.register_event_duration_secs_listener(_duration)
    log = logging.getLogger("jax._src.compiler")
    log.setLevel(logging.DEBUG)
    log.addHandler(_Missed())

    from jaxbelt.cli import main

    if sys.argv[1] != "--many":
        code = main(sys.argv[1:])
        with open(os.environ["JAXBELT_TEST_COUNTS"], "w") as f:
            json.dump(counts, f)
        sys.exit(code)
    # --many JSON: several commands one after another in this process, each counted apart, each one's stderr
    # after a marker line
    each = {}
    for name, argv in json.loads(sys.argv[2]).items():
        counts.update(requests=0, hits=0, compiles=0, missed=[], traced=0)
        print(f"=== {name} ===", file=sys.stderr, flush=True)
        each[name] = dict(counts, code=main(argv))
    with open(os.environ["JAXBELT_TEST_COUNTS"], "w") as f:
        json.dump(each, f)
''')


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    d = tmp_path_factory.mktemp("compile_cache")
    (d / "drive.toml").write_text(
        two_pulley_toml(n_elements=12, t_end=0.02, speed_ramp=(0.0, 0.01), load_ramp=(0.005, 0.015))
    )
    (d / "counter.py").write_text(COUNTER)
    t = np.arange(11) * 0.002  # "measured" driven speed for identify (any data: one iteration is run)
    rows = "".join(f"{a:.6g},{b:.6g}\n" for a, b in zip(t, 6.0 * np.minimum(t / 0.01, 1.0)))
    (d / "measured.csv").write_text("t,omega:driven\n" + rows)
    return d


def _counted(work, tag: str, argv: list[str], cache: str | None = "cache") -> tuple[dict, subprocess.CompletedProcess]:
    env = dict(os.environ, PYTHONUNBUFFERED="1", JAXBELT_TEST_COUNTS=str(work / f"{tag}.json"))
    env.pop("JAX_COMPILATION_CACHE_DIR", None)
    env["JAXBELT_CACHE_DIR"] = ""  # None: no cache at all
    if cache is not None:
        env["JAX_COMPILATION_CACHE_DIR"] = env["JAXBELT_CACHE_DIR"] = str(work / cache)
    env.pop("EQX_ON_ERROR", None)  # no environment variable is needed for caching
    env.pop("JAXBELT_STORED_PROGRAMS", None)  # stored traced programs as a user has them (conftest turns them off)
    # the notice after 0.5 s instead of 3 s: identify's Jacobian compiles for longer on any machine, while a cache
    # hit takes milliseconds (with 3 s the first process said nothing on a quiet machine)
    env["JAXBELT_COMPILE_NOTICE_S"] = "0.5"
    out = subprocess.run(
        [sys.executable, str(work / "counter.py"), *argv],
        capture_output=True,
        text=True,
        cwd=work,
        env=env,
        timeout=900,
    )
    assert out.returncode in (0, 1), out.stderr[-3000:]  # 1: a result flagged (this tiny transient may slip)
    return json.loads((work / f"{tag}.json").read_text()), out


CFG = "drive.toml"
COMMANDS = {
    "run": ["run", CFG, "--no-plots"],
    "statics": ["statics", CFG],
    "modes": ["modes", CFG, "--count", "4"],
    "runup": ["runup", CFG, "--rpm", "1500:1800", "--duration", "0.05", "--lead-time", "0.01", "--revolutions", "1"],
    "sweep": ["sweep", CFG, "--vary", "contact.mu=0.3:0.6:2"],
    "duty": ["duty", CFG, "--rpm", "100,200", "--torque", "driven=1,2"],
    "report": ["report", CFG],
    "identify": ["identify", CFG, "--measured", "measured.csv", "--fit", "belt.EA", "--iterations", "1"],
}
LOUD = {"identify"}  # not --quiet: the first process says it compiles (its Jacobian: seconds), the second not


@pytest.fixture(scope="module")
def two_processes(work):
    """Every command of COMMANDS in one process, then all again in a second one (two process starts instead of
    sixteen), each command counted apart. A program two commands share is compiled under the first process's
    first of them and loaded from the cache under the second process's: a command asks the cache for every
    program it needs that an earlier command of its own process had not already loaded."""
    argvs = {n: [*a, "--out", f"out_{n}", *([] if n in LOUD else ["--quiet"])] for n, a in COMMANDS.items()}
    return [_counted(work, f"commands-{i}", ["--many", json.dumps(argvs)]) for i in (1, 2)]


def _stderr_of(out: subprocess.CompletedProcess, name: str) -> str:
    return out.stderr.split(f"=== {name} ===\n", 1)[1].split("\n=== ", 1)[0]


@pytest.mark.long
@pytest.mark.parametrize("name", list(COMMANDS))
def test_second_process_compiles_nothing(two_processes, name):
    (counts1, out1), (counts2, out2) = two_processes
    first, second = counts1[name], counts2[name]
    assert first["code"] in (0, 1) and second["code"] == first["code"], (first, _stderr_of(out2, name)[-3000:])
    assert first["compiles"] == first["requests"], first  # every compile went through the cache
    # every program of the second process came from the cache: nothing was compiled; the run's and a sweep's
    # programs were loaded in their stored traced form (jax.export), not traced again
    assert second["missed"] == [] and second["hits"] == second["requests"] == second["compiles"], second
    assert second["traced"] == 0, second
    notice = f"jaxbelt {name}: {NOTICE}"
    said = (notice in _stderr_of(out1, name).splitlines(), notice in _stderr_of(out2, name))
    assert said == (name in LOUD, False), (_stderr_of(out1, name), _stderr_of(out2, name))


@pytest.mark.long
def test_the_two_processes_used_the_cache(two_processes):
    """The commands asked the cache at all (one whose every program an earlier command had loaded asks nothing;
    the eight together ask for many) and the second process found every program there."""
    (counts1, _), (counts2, _) = two_processes
    assert sum(c["requests"] for c in counts1.values()) > len(COMMANDS)
    assert sum(c["hits"] for c in counts2.values()) == sum(c["requests"] for c in counts2.values()) > len(COMMANDS)


def test_second_run_loads_the_traced_program_and_gets_the_same_result(work):
    """``jax.export``: a run stores its traced chunk program beside the compilation cache and the next process
    loads it, tracing nothing; its signals equal, to the digit, those of a process that traced the plain program
    without any cache."""
    argv = ["run", CFG, "--no-plots", "--quiet"]
    _counted(work, "export-1", [*argv, "--out", "export_1"])  # stores it (or finds it from an earlier test)
    second, _ = _counted(work, "export-2", [*argv, "--out", "export_2"])
    assert second["traced"] == 0 and list((work / "cache" / "jaxbelt-exported").glob("chunk-*.jaxexport")), second
    plain, _ = _counted(work, "export-plain", [*argv, "--out", "export_plain"], cache=None)
    assert plain["traced"] == 0 and plain["hits"] == 0  # no cache: the plain program, traced as before
    assert (work / "export_2" / "signals.csv").read_text() == (work / "export_plain" / "signals.csv").read_text()


@pytest.mark.long
def test_resumed_sweep_compiles_nothing(work):
    """A sweep killed after its first chunk, resumed by another process: that process loads the chunk program.
    The killed state is the one ``SweepStore`` leaves after one finished chunk of two (the manifest, the CSV
    with one row, that chunk's signals), made from a finished sweep of the same points."""
    argv = ["sweep", CFG, "--vary", "contact.mu=0.3:0.6:2", "--chunk-size", "1", "--quiet"]
    first, _ = _counted(work, "resume-1", [*argv, "--out", "whole"])
    assert first["requests"] > 0
    whole, killed = work / "whole", work / "killed"
    (killed / "sweep_signals").mkdir(parents=True)
    (killed / "sweep_manifest.json").write_text((whole / "sweep_manifest.json").read_text())
    header, row1 = (whole / "sweep.csv").read_text().splitlines()[:2]
    (killed / "sweep.csv").write_text(f"{header}\n{row1}\n")
    signals = dict(np.load(whole / "sweep_signals.npz"))
    np.savez(killed / "sweep_signals" / "chunk_000000.npz", **{k: v if k == "t" else v[:1] for k, v in signals.items()})
    second, out = _counted(work, "resume-2", [*argv, "--out", "killed", "--resume"])
    assert "1 of them done before" in out.stdout, out.stdout
    assert second["traced"] == 0, second  # the chunk program loaded traced
    assert (killed / "sweep.csv").read_text() == (whole / "sweep.csv").read_text()  # the same result, resumed
    assert second["missed"] == [] and second["hits"] == second["requests"] == second["compiles"] > 0, second


def test_save_time_checks_lose_their_callbacks_inside_jaxbelt_solves_only(monkeypatch):
    """``callback_free_checks``: diffrax's save-time checks, traced inside it, hold no host callback (so the
    program can be cached) and a failed check gives NaN; traced outside it, before or after, the user's
    equinox setting (``raise``, its default) is untouched: a callback, and a failed check raises."""
    import diffrax
    import equinox as eqx
    import jax
    import jax.numpy as jnp
    from equinox import _errors

    from jaxbelt._equinox_checks import callback_free_checks

    monkeypatch.setattr(_errors, "EQX_ON_ERROR", "raise")  # equinox's default, whatever the environment says
    own = _errors.branched_error_if_impl_jit

    def callbacks(scoped: bool) -> int:
        def solve(ts):  # a new vector field each time: diffrax's own jit traces it again
            term = diffrax.ODETerm(lambda t, y, args: -y)
            sol = diffrax.diffeqsolve(term, diffrax.Euler(), 0.0, 1.0, 0.1, 1.0, saveat=diffrax.SaveAt(ts=ts))
            return sol.ys

        with callback_free_checks() if scoped else contextlib.nullcontext():
            text = jax.jit(solve).lower(jnp.linspace(0.0, 1.0, 5)).as_text()
        return text.count("callback")

    assert callbacks(scoped=True) == 0
    assert callbacks(scoped=False) > 0  # traced after the scoped one: equinox's own form
    assert _errors.branched_error_if_impl_jit is own

    def checked(x):  # traced once, in scope (jax.jit would reuse that trace for the same function)
        return eqx.error_if(x, x > 0, "x must be <= 0")

    with callback_free_checks():
        assert jnp.isnan(jax.jit(checked)(jnp.array(1.0)))

    def checked_outside(x):
        return eqx.error_if(x, x > 0, "x must be <= 0")

    with pytest.raises(Exception, match="x must be <= 0"):
        jax.jit(checked_outside)(jnp.array(2.0))


def test_xla_log_lines_reach_the_user_only_when_asked_for(tmp_path):
    """XLA's C++ log (its "Very slow compile?" banner is an error line, after two minutes of one program) is
    silenced while a command runs; a user's TF_CPP_MIN_LOG_LEVEL is kept. A quick error line of the same
    log: a dump directory XLA cannot create (below a file)."""
    (tmp_path / "drive.toml").write_text(
        two_pulley_toml(n_elements=12, t_end=0.02, speed_ramp=(0, 0.01), load_ramp=(0, 0.01))
    )
    (tmp_path / "afile").write_text("")
    env = dict(os.environ, XLA_FLAGS=f"{os.environ.get('XLA_FLAGS', '')} --xla_dump_to={tmp_path / 'afile' / 'sub'}")
    env.pop("TF_CPP_MIN_LOG_LEVEL", None)  # as in a user's shell (JAX sets it in this process)
    cmd = [sys.executable, "-m", "jaxbelt", "statics", "drive.toml", "--out", "out", "--quiet", "--no-cache"]
    quiet = subprocess.run(cmd, capture_output=True, text=True, cwd=tmp_path, env=env, timeout=600)
    loud = subprocess.run(cmd, capture_output=True, text=True, cwd=tmp_path, env=dict(env, TF_CPP_MIN_LOG_LEVEL="0"))
    assert quiet.returncode == loud.returncode == 0, (quiet.stderr[-2000:], loud.stderr[-2000:])
    assert "Could not create directory" in loud.stderr  # XLA logs that error line ...
    assert "dump.cc" not in quiet.stderr, quiet.stderr  # ... which the user does not see unless asked for


class _Timer:
    """A timer that fires when the test says (``CompileNotice.timer_class``)."""

    made: list = []

    def __init__(self, delay, function):
        self.function, self.args, self.cancelled = function, (), False
        _Timer.made.append(self)

    def start(self):
        pass

    def cancel(self):
        self.cancelled = True

    def fire(self):
        if not self.cancelled:
            self.function(*self.args)


def _notice(monkeypatch, *steps: str) -> list[str]:
    """What ``CompileNotice`` says for JAX's compile events (recorded here as JAX records them) and the
    armed timer running out ("fire")."""
    from jax import monitoring

    monkeypatch.setattr(CompileNotice, "timer_class", _Timer)
    _Timer.made = []
    said: list[str] = []
    with CompileNotice(said.append):
        for step in steps:
            if step == "fire":
                for timer in _Timer.made:
                    timer.fire()
            elif step == "compiled":
                monitoring.record_event_duration_secs("/jax/core/compile/backend_compile_duration", 0.5)
            elif step == "miss":  # JAX announces a missed lookup just before it compiles
                from jax._src import util

                util.test_event("compile_after_persistent_compilation_miss")
            else:
                monitoring.record_event(f"/jax/compilation_cache/{step}")
    return said


def test_compile_notice_once_for_a_long_compile_never_for_a_cache_hit(monkeypatch):
    lookup = "compile_requests_use_cache"
    # a missed lookup, then the compile runs past the delay: said once, however many programs follow
    assert _notice(monkeypatch, lookup, "miss", "fire", lookup, "miss", "compiled", lookup, "miss", "fire") == [NOTICE]
    # a lookup answered from the cache, or a compile that finished before the delay: nothing said
    assert _notice(monkeypatch, lookup, "cache_hits", "fire", lookup, "miss", "compiled", "fire") == []
    assert len(_Timer.made) == 1 and all(t.cancelled for t in _Timer.made)
    # a large program loading from the cache past the delay (a busy machine): nothing armed, nothing said
    assert _notice(monkeypatch, lookup, "fire", "cache_hits") == [] and _Timer.made == []


def test_compile_notice_with_a_real_timer():
    said: list[str] = []
    fired = threading.Event()
    with CompileNotice(lambda text: (said.append(text), fired.set()), delay=0.01):
        from jax import monitoring

        from jax._src import util

        monitoring.record_event("/jax/compilation_cache/compile_requests_use_cache")
        util.test_event("compile_after_persistent_compilation_miss")
        assert fired.wait(timeout=60)
    assert said == [NOTICE]


@pytest.mark.long
def test_a_gradient_through_a_run_holds_no_host_callback():
    """A reverse-mode gradient through ``simulate`` (diffrax's checkpointed adjoint: its backward pass is
    traced when JAX transposes, after ``simulate`` returned) holds no host callback either: it can be cached."""
    import jax
    import jax.numpy as jnp

    import jaxbelt as jb

    with pytest.warns(UserWarning, match="wrapped by belt elements"):
        drive = jb.build_drive(jb.benchmark_a(n_elements=12, t_end=0.01, save_dt=0.005))

    def loss(params):
        run = jb.simulate(drive.model, params, drive.state0, t_end=0.01, dt=drive.dt, save_dt=0.005, settle_time=0.005)
        return jnp.sum(run.states.q**2)

    assert jax.jit(jax.grad(loss)).lower(drive.params).as_text().count("callback") == 0


def test_stored_programs_follow_the_cache_and_can_be_turned_off(monkeypatch, tmp_path):
    """Stored traced programs live beside the compilation cache; JAXBELT_STORED_PROGRAMS=0 (false, no, off) turns
    them off (programs traced as before), any other value or none keeps them."""
    from types import SimpleNamespace

    import jaxbelt._export as ex

    # the cache directory as JAX's config would give it (the process's own cache left alone)
    monkeypatch.setattr(ex, "jax", SimpleNamespace(config=SimpleNamespace(jax_compilation_cache_dir=str(tmp_path))))
    for value, on in (("0", False), ("off", False), ("No", False), ("1", True), ("", True)):
        monkeypatch.setenv("JAXBELT_STORED_PROGRAMS", value)
        assert ex.export_dir() == (tmp_path / "jaxbelt-exported" if on else None), value
    monkeypatch.delenv("JAXBELT_STORED_PROGRAMS")
    assert ex.export_dir() == tmp_path / "jaxbelt-exported"


def test_a_stored_jit_is_traced_once_and_loaded_by_a_new_one(monkeypatch, tmp_path):
    """``StoredJit`` (the modes programs): the first object traces and stores its program, a second one (as in a
    later process) loads it without tracing; both give ``jax.jit``'s result, to the bit. Traced arguments (inside
    ``jax.grad``) and non-array ones take ``jax.jit`` itself."""
    import jax
    import jax.numpy as jnp

    import jaxbelt._export as ex

    monkeypatch.setattr(ex, "export_dir", lambda: tmp_path)
    exports: list = []
    export = jax.export.export
    monkeypatch.setattr(jax.export, "export", lambda *a, **kw: (exports.append(1), export(*a, **kw))[1])

    def fn(p, x):
        return {"y": p["a"] * jnp.sin(x), "z": [jnp.sum(x**2) * p["a"]]}

    def stored():
        return ex.StoredJit("stored_test", fn, ("what fn closes over", 1), {"y": 0, "z": [0]})

    args = ({"a": jnp.asarray(2.0)}, jnp.linspace(0.0, 1.0, 5))
    first, second, plain = stored()(*args), stored()(*args), jax.jit(fn)(*args)
    assert len(exports) == 1 and len(list(tmp_path.glob("stored_test-*.jaxexport"))) == 1
    for out in (first, second):
        assert jax.tree.structure(out) == jax.tree.structure(plain)
        assert all(np.array_equal(a, b) for a, b in zip(jax.tree.leaves(out), jax.tree.leaves(plain)))
    grad = jax.grad(lambda a: stored()({"a": a}, args[1])["z"][0])(2.0)
    assert float(grad) == pytest.approx(float(jnp.sum(args[1] ** 2)), rel=1e-12) and len(exports) == 1
    # a Python number would be baked into the program: jax.jit too, never another argument's stored program
    z = stored()({"a": 3.0}, args[1])["z"][0]
    assert float(z) == pytest.approx(3.0 * float(jnp.sum(args[1] ** 2)), rel=1e-12) and len(exports) == 1
