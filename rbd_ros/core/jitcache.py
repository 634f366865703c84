# Copyright 2026 The rbd_ros authors
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

"""
Where numba caches the compiled kernels: a private per-user directory, never the package.

numba loads its on-disk cache with :mod:`pickle`, so whoever can write the cache directory can
run code as whoever imports :mod:`rbd_ros.core`. The cache therefore lives in
``$NUMBA_CACHE_DIR`` if the user set it, else ``$XDG_CACHE_HOME/rbd_ros/numba`` (an absolute
``XDG_CACHE_HOME``), else ``~/.cache/rbd_ros/numba``, by the one rule for cache folders
(:mod:`rbd_ros.core.cachedir`): directories we use get mode 0700. A
directory not owned by the current user or writable by group or others is refused: the kernels
are then compiled in memory at every start (:data:`CACHE_DIR` is None, :data:`PROBLEM` says
why, and a warning goes to the ``rbd_ros`` logger). numba's default, ``__pycache__`` next to the
installed sources, is never used.

Nothing happens at import: :func:`kernel` decorates without a cache and keeps the dispatcher;
:func:`configured` (called when a simulator is built, by the warm-up and by the cache queries
below) chooses the directory once, sets ``NUMBA_CACHE_DIR`` for child processes and turns on
every kept dispatcher's cache (numba's public ``Dispatcher.enable_caching``, what
``njit(cache=True)`` itself calls), before anything is compiled.

**One cache for every copy of the same sources.** numba's own locators key a cache by the
directory the source file sits in and its modification time, so a ``colcon build`` install, a
``pip install`` or a second checkout of the very same version compiled everything again on its
first start (minutes, for the contact step). :class:`SourceCacheLocator` keys it by the
module's name and a SHA-256 of the source file's bytes instead, inside a directory named after
the layout and every kernel source (``layout-<hash>``, see
:func:`rbd_ros.core.layout.fingerprint_hash`). It is installed through numba's
``NUMBA_CACHE_LOCATOR_CLASSES`` setting, ahead of numba's own locators, which still serve
every function that is not ``rbd_ros``'s.

**One specialisation per argument type.** numba compiles a function called from another kernel
for the exact types of the call, and a constant argument (``True``, a phase number) is typed as
that literal value: each distinct constant compiled the callee and its whole subtree again (the
contact step's sweeps four times; 195 s of one core for its first compile, 74 s since).
:func:`kernel` makes every dispatcher ask for the plain types instead (:func:`_once_per_type`).

**One copy of an inlined helper's variables, not one per block.** A helper compiled with
``inline='always'`` is inlined at numba-IR level: at every call site numba's
``InlineWorker.inline_ir`` copies the helper's IR, one ``copy.deepcopy`` per block, and every
variable refers to the function's scope, so each block's copy copied every variable of the
helper again (blocks × variables): 15 of the 33 s of CPU of a cold free-body compile.
:func:`_share_inline_copies` lets the blocks of one copy share one memo, as a deep copy of the
whole IR would; the machine code is byte for byte the same (compared with ``inspect_asm`` of
every kernel of the free-body step).

**One set of compile options.** Every kernel is compiled through :func:`kernel`: IEEE float
semantics (``error_model='numpy'``: a division by zero gives ±inf or nan, which the step's
finiteness check turns into :class:`~rbd_ros.core.errors.NonFiniteError`, where numba's default
raised ``ZeroDivisionError`` out of the middle of a step), no ``fastmath`` (no reassociation:
bit-for-bit results), and the GIL released.
"""

import copy
import functools
import hashlib
import logging
import os
import sys

from numba.core import caching
from rbd_ros.core import cachedir, layout

_LOG = logging.getLogger('rbd_ros')

#: The cache directory in use, or None (no on-disk cache); set by :func:`configure`.
CACHE_DIR = None
#: Why the cache is off (one line), or None.
PROBLEM = None
#: The locators numba tries, in order: ours first (for rbd_ros's functions), then numba's own.
LOCATORS = ('rbd_ros.core.jitcache.SourceCacheLocator', 'UserProvidedCacheLocator',
            'InTreeCacheLocator', 'UserWideCacheLocator', 'IPythonCacheLocator',
            'ZipCacheLocator')
#: What every kernel is compiled with (see the module docstring).
OPTIONS = {'error_model': 'numpy', 'fastmath': False, 'nogil': True}
#: Name of the file :func:`mark_compiled` leaves in the cache directory once a kind of kernel
#: (:data:`KIND_MODULES`) has been compiled and stepped there.
MARK = 'compiled-{kind}'


def default_dir(environ=None):
    """Return ``numba`` in :func:`rbd_ros.core.cachedir.base_dir` (the cache folder rule)."""
    return os.path.join(cachedir.base_dir(environ), 'numba')


#: Why a directory must not hold the cache (:func:`rbd_ros.core.cachedir.unsafe_reason`).
unsafe_reason = cachedir.unsafe_reason


def configure(environ=None, subdir=None):
    """
    Choose numba's cache directory (see the module docstring); return it, or None if refused.

    :param subdir: a directory below it to use instead (created and checked the same way).

    Sets ``NUMBA_CACHE_DIR`` in ``environ`` (numba re-reads its configuration from the
    environment when it compiles) and ``numba.config.CACHE_DIR`` if numba is already imported.
    """
    global CACHE_DIR, PROBLEM
    environ = os.environ if environ is None else environ
    user_set = bool(environ.get('NUMBA_CACHE_DIR'))
    path = os.path.abspath(environ['NUMBA_CACHE_DIR'] if user_set else default_dir(environ))
    # Our own directories: the leaf, and for the default also <cache>/rbd_ros above it (whoever
    # owns a parent can swap the leaf).
    ours = [path] if user_set else [os.path.dirname(path), path]
    # A process started by one that imported rbd_ros inherits its NUMBA_CACHE_DIR, which
    # already ends in ``subdir``: nesting it again gave the child a cache of its own, so a node
    # started from Python (a test, a launch script) compiled for minutes on every new checkout.
    if subdir and os.path.basename(path) != subdir:
        path = os.path.join(path, subdir)
        ours.append(path)
    refused = cachedir.make_private(ours)  # outermost first: nothing below a refused one
    problem = None
    if refused is not None:
        problem = f'numba cache directory {refused[0]}: {refused[1]}; compiling the physics ' \
                  'kernels in memory at every start (no on-disk cache)'
    CACHE_DIR, PROBLEM = (None, problem) if problem else (path, None)
    if problem:
        _LOG.warning(problem)
        return None
    environ['NUMBA_CACHE_DIR'] = path
    environ['NUMBA_CACHE_LOCATOR_CLASSES'] = ','.join(LOCATORS)
    config = sys.modules['numba.core.config']  # imported with numba.core.caching above
    config.CACHE_DIR = path
    config.CACHE_LOCATOR_CLASSES = environ['NUMBA_CACHE_LOCATOR_CLASSES']
    return path


_CONFIGURED = False
#: The dispatchers :func:`kernel` made before :func:`configured` ran; their caches are turned on
#: then.
_PENDING = []


def configured():
    """
    Run :func:`configure` for this layout once, and turn on the cache of every kernel so far.

    Called when a simulator is built (before its first compile), by the warm-up and by the cache
    queries below; importing a kernel module does not (no directories, no environment).
    """
    global _CONFIGURED
    if not _CONFIGURED:
        configure(subdir=f'layout-{layout.fingerprint_hash()}')
        _CONFIGURED = True
        if CACHE_DIR is not None:
            for dispatcher in _PENDING:
                dispatcher.enable_caching()
        _PENDING.clear()
    return CACHE_DIR


def kernel(**options):
    """
    Return numba's ``njit`` decorator with :data:`OPTIONS` and ``options``, cached on disk.

    ``options`` adds to or overrides :data:`OPTIONS` (``inline='always'`` for small helpers,
    ``parallel=True``). The disk cache is turned on by :func:`configured` (at once if it ran
    already and found a usable directory), so decorating touches no file.
    """
    import numba
    _share_inline_copies()
    jit = numba.njit(**{**OPTIONS, **options})

    def decorate(function):
        dispatcher = jit(function)
        _once_per_type(dispatcher)
        if not _CONFIGURED:
            _PENDING.append(dispatcher)
        elif CACHE_DIR is not None:
            dispatcher.enable_caching()
        return dispatcher
    return decorate


def _once_per_type(dispatcher):
    """
    Make ``dispatcher`` compile once per argument *type* when called from a kernel; return it.

    numba types a constant argument of a call between jitted functions as a literal
    (``Literal[bool](True)``) and compiles the callee, and everything it calls, again for every
    constant value it is called with (see the module docstring). The call template is asked
    for with the constants' plain types (numba's ``unliteral``), so one specialisation serves
    every value; the run-time branch on the value costs nothing measurable (bench_contact, within
    2 %). ``get_call_template`` is what numba's typing of a call asks a dispatcher
    (``types.Dispatcher.get_call_type``); numba is pinned, and
    ``tests/core/test_jitcache.py`` checks that a constant no longer adds a specialisation.
    Helpers inlined at numba-IR level (``inline='always'``) are not called this way and keep
    seeing their constants.
    """
    from numba.core import types
    ask = dispatcher.get_call_template

    def get_call_template(args, kws):
        return ask(tuple(types.unliteral(a) for a in args),
                   {k: types.unliteral(v) for k, v in kws.items()})
    dispatcher.get_call_template = get_call_template
    return dispatcher


class _InlineCopy:
    """
    What numba's ``inline_closurecall`` module sees as :mod:`copy` (see the module docstring).

    Its one use there is ``copy.deepcopy(block)`` in ``InlineWorker.inline_ir``, for each block
    of the IR it inlines, twice a call site (a working copy and a copy of that). While
    :attr:`memos` is a dict (during one ``inline_ir``), the blocks of one scope share one memo,
    so the scope and its variables are copied once for the whole IR; a copy of that copy has
    another scope, hence its own memo. Outside ``inline_ir`` it is :func:`copy.deepcopy`.
    """

    copy = staticmethod(copy.copy)

    def __init__(self):
        """Start outside ``inline_ir``."""
        self.memos = None

    def deepcopy(self, value, memo=None):
        """Return :func:`copy.deepcopy` of ``value``, sharing a memo per scope in inline_ir."""
        from numba.core import ir
        if memo is None and self.memos is not None and isinstance(value, ir.Block):
            memo = self.memos.setdefault(id(value.scope), {})
        return copy.deepcopy(value, memo)


_INLINE_COPY = _InlineCopy()


def _share_inline_copies():
    """
    Install :class:`_InlineCopy` in numba's ``inline_closurecall``, once; return the module.

    ``InlineWorker.inline_ir`` is wrapped to open a fresh set of memos when it starts and to
    drop them when it returns (an object's ``id`` may be reused once it is freed). numba is
    pinned; ``tests/core/test_jitcache.py`` checks that the blocks of an inlined helper's copy
    share one scope and that the kernels give the same results.
    """
    from numba.core import inline_closurecall as module
    if getattr(module, 'copy', None) is _INLINE_COPY:
        return module
    worker = getattr(module, 'InlineWorker', None)
    inline_ir = getattr(worker, 'inline_ir', None)
    if getattr(module, 'copy', None) is not copy or inline_ir is None:
        return module  # another numba than the pinned one: its own copies (slower, not wrong)

    @functools.wraps(inline_ir)
    def inline_ir_sharing(self, *args, **kwargs):
        outer, _INLINE_COPY.memos = _INLINE_COPY.memos, {}
        try:
            return inline_ir(self, *args, **kwargs)
        finally:
            _INLINE_COPY.memos = outer
    worker.inline_ir = inline_ir_sharing
    module.copy = _INLINE_COPY
    return module


def raw_kernel(**options):
    """
    Return :func:`kernel` for a function compiled without numba's reference counting.

    The one use of a private numba option, ``_nrt=False``: numba has no public way to turn off
    reference counting for one function, and its atomic updates were ~60 % of a step of 1000
    resting boxes (see :mod:`rbd_ros.core.contact.step`, "Reference counts"). Only for
    functions that allocate nothing and call none that do.
    """
    return kernel(_nrt=False, **options)


class SourceCacheLocator(caching.UserProvidedCacheLocator):
    """
    numba's cache of an ``rbd_ros`` function, keyed by module name and source bytes, not path.

    The functions of module ``rbd_ros.core.x`` go to ``<CACHE_DIR>/rbd_ros.core.x``; an entry is
    valid while the source file's SHA-256 is the one it was compiled from. Any other function
    is left to numba's own locators (``from_function`` returns None).
    """

    def __init__(self, py_func, py_file):
        """Put the cache of ``py_func`` in ``<CACHE_DIR>/<its module>``."""
        super().__init__(py_func, py_file)
        self._cache_path = os.path.join(CACHE_DIR, py_func.__module__)

    def get_source_stamp(self):
        """Return the SHA-256 of the source file (not its time and size, as numba's)."""
        with open(self._py_file, 'rb') as source:
            return hashlib.sha256(source.read()).hexdigest()

    @classmethod
    def from_function(cls, py_func, py_file):
        """Serve functions of the ``rbd_ros`` package when a cache directory is in use."""
        module = getattr(py_func, '__module__', '') or ''
        if CACHE_DIR is None or not (module == 'rbd_ros' or module.startswith('rbd_ros.')):
            return None
        return super().from_function(py_func, py_file)


#: The kinds of kernel a first step compiles, and the module whose cache files show it on disk.
KIND_MODULES = {'free': 'rbd_ros.core.kernels', 'contact': 'rbd_ros.core.contact.step',
                'joints': 'rbd_ros.core.joints.kernels',
                'world_joints': 'rbd_ros.core.contact.step'}
#: What the node's notice calls each kind.
KIND_NAMES = {'free': 'the free-body step', 'contact': 'the contact step',
              'joints': 'the joints and robots step',
              'world_joints': 'the contact step with joints'}
#: Roughly how long a first compile takes on a 2-core machine (s), to tell the user (measured
#: with an empty cache on 2026-12-06 with ``python -m rbd_ros.core.warmup``, one kind at a time:
#: free 20-37 s, contact 113-131 s, joints 100-112 s; on 2026-12-07 the contact step with joints
#: 252 s of CPU from nothing, 88 s once the contact step is compiled: :data:`COMPILE_AFTER_S`;
#: later on 2026-12-07, with an inlined helper's IR copied once (:func:`_share_inline_copies`),
#: one core, quiet: free 17 s, contact 106 s, joints 85 s; the contact step with joints not
#: measured quiet since; see doc/benchmarks.md).
COMPILE_S = {'free': 17, 'contact': 105, 'joints': 85, 'world_joints': 250}
#: A kind whose compile reuses another's compiled stages: ``{kind: (the other, seconds)}``.
COMPILE_AFTER_S = {'world_joints': ('contact', 90)}


def _mark(kind):
    return os.path.join(CACHE_DIR, MARK.format(kind=kind))


def kernels_on_disk(kind='free'):
    """
    Return True when this version's step kernel of ``kind`` (:data:`KIND_MODULES`) is on disk.

    :func:`mark_compiled` leaves a mark in the cache directory (whose name changes with every
    kernel source, see the module docstring) after a first step of that kind compiled there;
    numba's index files must be there too. Reads file names only; compiles nothing.
    """
    if configured() is None or not os.path.isfile(_mark(kind)):
        return False
    try:
        return any(name.endswith('.nbi')
                   for name in os.listdir(os.path.join(CACHE_DIR, KIND_MODULES[kind])))
    except OSError:
        return False


def compile_notice(kind='free'):
    """Return the one line the node logs before a step that compiles (what, how long, where)."""
    configured()
    where = (f'once per version; cached in {CACHE_DIR}' if CACHE_DIR else
             f'at every start: {PROBLEM}')
    seconds = COMPILE_S[kind]
    if kind in COMPILE_AFTER_S and kernels_on_disk(COMPILE_AFTER_S[kind][0]):
        seconds = COMPILE_AFTER_S[kind][1]
    return (f'compiling the physics kernels ({KIND_NAMES[kind]}: about {seconds} s on a '
            f'2-core machine, {where})')


def mark_compiled(kind='free'):
    """Leave the mark :func:`kernels_on_disk` looks for, after a first step that compiled."""
    if configured() is None:
        return
    try:
        with open(_mark(kind), 'a'):
            pass
    except OSError as exc:
        _LOG.warning(f'cannot write {_mark(kind)} ({exc.strerror}): the next start will say '
                     'it compiles although it loads from the cache')
