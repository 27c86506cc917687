"""The JIT policy: every compiled function of the library goes through here.

Three decorators,

* `kernel` - a function compiled on its own (an entry point called from
  Python): numba.njit(nogil=True, error_model="numpy") without numba's
  reference-counted runtime (NRT), cached on disk.
* `helper` - a small function called from kernels, compiled on its own and
  linked into them; LLVM's inliner inlines it where that pays (the substrate
  motion, the records, the integrator steps: all inlined in practice).
* `inline` - inlined at numba IR level into every caller (inline="always"):
  for hot code that LLVM would leave as a call, because the call passes many
  arrays (each one several arguments) or the body is large: the memory
  diagram's commit and clamp, the material point's event functions and
  its two event searches (one call site each; as helpers: runs ~20% slower);
  the Hertz kernels' prediction of a contact step (`_predict`: as a helper
  it stayed a call in every step, and every float live across a call is
  spilled to the stack and reloaded around it, all xmm registers being
  caller-saved: inlined, each step of every Hertz kernel ~4 ns cheaper).

and `template`, `specialize` for code written once for several variants
(the Hertz kernels' model, Lyapunov tangent and contact law's kind): each
variant a copy whose flags are global names, not arguments.  numba freezes
globals as constants and drops the branches they decide before it inlines
and types the rest, where a flag passed as an argument, even a literal one,
leaves every branch to inline, type and lower: the sphere's deformable
kernel carried the profiles' memory diagram and warm-started roots, unused.
Measured on this 2-core machine, empty cache (a cold `vibtrans simulate
--log-amplitude 2.5 --log-mass 0`, one kernel with its Lyapunov tangent):
25 s with the flags as arguments, 11-12.5 s as copies' globals; the same
records bit for bit (`python -m devtools.fingerprint`).

Why no NRT (measured): our kernels never allocate: they work in arrays their
caller owns (and keeps alive) and return plain numbers.  With NRT on, every
call of an inlined helper that takes arrays (the memory diagram's
push/pop/clamp, the history, the records) increments and decrements the
arrays' reference counts, atomically, at every step: that was ~40% of a
memory-diagram update (35 -> 21 ns; `vibtrans bench`).  Without NRT an
allocation inside a kernel fails to compile, which keeps them
allocation-free.

Why error_model="numpy": a float division by zero gives inf or NaN (IEEE)
instead of raising ZeroDivisionError from inside a kernel.  Results are the
same wherever the divisor is not zero; where it is (scenes at the edge of
the float range, e.g. tau* = 5e-324, where tau*^2 underflows to 0), the run
goes on with inf/NaN values, which the step estimate and the bounded event
searches keep finite in time, instead of ending in a traceback.

Why two kinds of inlining (measured on this 2-core machine, empty cache,
compile seconds deformable / point mass / vertical):

* everything through `inline`: 39 / 19 / 26 s.  Numba copies the callee's IR
  at every inlined call, deep-copying each block with the function's whole
  variable scope: the cost grows with call sites times size.
* everything through `helper`: 14 / 7.5 / 3.5 s, the same results bit for bit
  (no fast-math: LLVM keeps the order of every floating-point operation), the
  vertical kernel as fast, but a memory-diagram update 3x slower (63 vs 21
  ns: LLVM leaves the clamp as a call with ~40 arguments).
* as now (the memory diagram `inline`, with one call site of the clamp;
  the point mass's event functions `inline`): 11.6 / 7.1 / 3.5 s, the
  memory diagram and the deformable kernel as fast as all-`inline`
  (`vibtrans bench`), the point mass within ~10%.
* the kernels are named phases, most of them `helper`s, each compiled on
  its own once per signature (~0.1-0.2 s a helper); run times as above.
* no wrapper is compiled that only Python would call: no cfunc wrapper
  anywhere, no CPython wrapper on a helper (`_HelperDispatcher`), about a
  tenth of a cold `vibtrans simulate`'s compilation, the same records bit
  for bit (`vibtrans bench --cold-start`).

The on-disk cache.  numba's own cache checks only the source file of the
function it compiled: an edit to a helper inlined from another module left a
stale kernel in the cache (hence the old `make clean-cache`).  Here the cache
folder is keyed by a hash of the source text of every module holding compiled
code (`SOURCES`, checked at decoration time) and of the numba version, so an
edit anywhere in the compiled code selects a fresh folder: a stale kernel
cannot be loaded.  Environment:

* VIBTRANS_JIT_CACHE=0 disables the on-disk cache (every process compiles);
* NUMBA_CACHE_DIR, if set, is the base folder, else $XDG_CACHE_HOME/vibtrans/numba
  (~/.cache/vibtrans/numba); the cache lives in <base>/<key>/.

Only the library's functions use that folder: numba's global setting is
switched to it just while one of our functions is decorated, so other
libraries' numba caches stay where they were.
"""

import contextlib
import hashlib
import os
import types
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numba
from numba import config as _numba_config
from numba import njit
from numba.core.registry import CPUDispatcher

# Every module that defines a compiled function (all in this package).
SOURCES = (
    "jit.py",
    "records.py",
    "contact.py",
    "substrate.py",
    "integrators.py",
    "deformable.py",
    "point_mass.py",
)
_PACKAGE = Path(__file__).resolve().parent
_MODULES = frozenset(f"{__package__}.{s[:-3]}" for s in SOURCES)


def _source_key():
    """Hash of the compiled modules' source text and the numba version
    (None if a source cannot be read, e.g. a zipped install: no cache then)."""
    digest = hashlib.sha256(numba.__version__.encode())
    for name in SOURCES:
        try:
            text = (_PACKAGE / name).read_bytes()
        except OSError:
            return None
        digest.update(name.encode() + b"\0" + text + b"\0")
    return digest.hexdigest()[:16]


def _cache_base():
    base = os.environ.get("NUMBA_CACHE_DIR")
    if base:
        return Path(base)
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "vibtrans" / "numba"


CACHE_ENABLED = os.environ.get("VIBTRANS_JIT_CACHE", "1").strip().lower() not in ("0", "false", "no", "off")
_KEY = _source_key() if CACHE_ENABLED else None
CACHE_DIR = str(_cache_base() / _KEY) if _KEY else None


# Compiled without the cfunc wrapper (the C-callable entry numba adds for
# first-class function values, unused here): a wrapper per function is
# LLVM code to optimize and emit, on every compile.
_OPTIONS = {"nogil": True, "_nrt": False, "error_model": "numpy", "no_cfunc_wrapper": True}


class _HelperDispatcher(CPUDispatcher):
    """A helper's dispatcher: compiled for kernels to call, without the
    CPython wrapper (the boxing and unboxing of every argument, as much code
    as the helper itself); numba's call of such a function from Python would
    crash, so a call from Python goes to a twin that has the wrapper
    (compiled on its first call, not cached: only tests call helpers so)."""

    _python_twin = None

    def __call__(self, *args, **kwargs):
        if self._python_twin is None:
            self._python_twin = njit(**_OPTIONS)(self.py_func)
        return self._python_twin(*args, **kwargs)


def _compile(fn, dispatcher=None, **options):
    if fn.__module__ not in _MODULES:
        raise RuntimeError(
            f"{fn.__module__}.{fn.__qualname__}: compiled code must live in "
            f"a module listed in vibtrans.core.kernels.jit.SOURCES (the cache key)"
        )
    if dispatcher is None:
        disp = njit(cache=False, **_OPTIONS, **options)(fn)
    else:
        targetoptions = {"nopython": True, **_OPTIONS, **options}
        disp = dispatcher(py_func=fn, locals={}, targetoptions=targetoptions)
    if CACHE_DIR is not None:
        saved = _numba_config.CACHE_DIR
        _numba_config.CACHE_DIR = CACHE_DIR
        try:
            disp.enable_caching()  # the locator reads the folder now
        finally:
            _numba_config.CACHE_DIR = saved
    return disp


def kernel(fn: Callable) -> Any:
    """Compile `fn` on its own: allocation-free, GIL-free, disk-cached."""
    return _compile(fn)


def helper(fn: Callable) -> Any:
    """A small function for kernels to call; LLVM inlines it where that pays."""
    return _compile(fn, _HelperDispatcher, no_cpython_wrapper=True)


def inline(fn: Callable) -> Any:
    """Inline `fn` at numba IR level into each caller (compile time per call
    site: keep the call sites few)."""
    return _compile(fn, inline="always")


@contextlib.contextmanager
def compile_notice(report: Callable[[str], object]) -> Iterator[None]:
    """Within the block, report(name) once, as numba starts compiling one of
    the library's functions (name: its qualified name); loading one from
    the disk cache is not compiling.  For front ends, which say so while
    the first run after an install or an edit compiles."""
    from numba.core import event

    class Notice(event.Listener):
        told = False

        def on_start(self, ev):
            fn = ev.data["dispatcher"].py_func
            if not self.told and fn.__module__ in _MODULES:
                self.told = True
                report(fn.__qualname__)

        def on_end(self, ev):
            pass

    with event.install_listener("numba:compile", Notice()):
        yield


def template(decorate: Callable) -> Callable[[Callable], Callable]:
    """Mark `fn` as a template: not compiled itself, only in the copies
    `specialize` makes, each with `decorate` (kernel, helper or inline)."""

    def mark(fn):
        fn.jit_decorator = decorate
        return fn

    return mark


def specialize(templates: Sequence[Callable], name: str, **constants: Any) -> dict[str, Any]:
    """Compiled copies of `templates` (functions of one module, `template`)
    whose global names also hold `constants` (and each other's copies).

    numba freezes a global as a compile-time constant and drops the branches
    it decides before it inlines and types the rest: a copy for the sphere
    leaves the profiles' code out, where a flag passed as an argument would
    have it inlined and compiled, unused (a Hertz kernel compiles in half the
    time).  `name` (the constants in words) joins each copy's qualified name:
    numba's disk cache tells the copies apart by it.  Returns the copies'
    namespace: copy = namespace[template's name]."""
    namespace = dict(templates[0].__globals__)
    namespace.update(constants)
    for fn in templates:
        copy = types.FunctionType(fn.__code__, namespace, fn.__name__, fn.__defaults__, fn.__closure__)
        copy.__qualname__ = f"{fn.__qualname__}__{name}"
        copy.__doc__ = fn.__doc__
        namespace[fn.__name__] = fn.jit_decorator(copy)
    return namespace
