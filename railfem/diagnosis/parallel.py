"""Tasks of the diagnosis (candidates screened, pairs refitted) in parallel processes.

``run(fn, items, workers, shared, groups)`` runs ``fn(item)`` for every item and yields
``(index, ok, value)`` (value: fn's result, or the exception it raised). With ``workers``
> 1 the items run in worker processes started with the 'fork' method after the base fit:
the workers inherit the parent's state (data, base refit, the evaluator's kernels and
eigen forms in memory) for free. A kernel a worker computes reaches the others, and the
parent, through the on-disk kernel cache (railfem.track.kernelcache) only, so items that
share kernels (the rail-loss lattice of support effects, the Woodbury form of deviating
supports, the banks of shifted geometries) are given as one group, run in turn in one
worker in their own order, as a serial run would.

* **Log**: an item's log records are collected in its worker and handled by the parent
  when the item is done, together (its kernels, then its result), so the log and a
  progress bar reading it advance candidate by candidate, in the order they finish.
* **Results** come back pickled, the objects the parent already holds (``shared``: the
  evaluator, the data, the effects of the library) by reference: an Outcome's problem
  then evaluates with the parent's evaluator. The caller puts them in the items' order.
* **Failures**: an exception of an item is its value (ok False); the caller reports it and
  goes on. **Ctrl-C** reaches the parent only (the workers ignore SIGINT): the pool is
  terminated and KeyboardInterrupt raised.
* **BLAS** runs on one thread per worker (threadpoolctl). With one BLAS thread in the
  parent as well (the command line's and the tests' setting) the results are the serial
  run's to the last bit; a parent on threaded BLAS differs from its workers by round-off
  (1e-15 in an eigen form), which a refit's stopping rule can carry to ~1e-6 along a
  flat direction.

``prefetch`` computes ahead, in the workers, the kernels a serial step of the diagnosis
will ask for (the base step's discrepancy variants and rail-loss neighbours,
``base_kernels``; the final refit's first rail-loss kernels), into the on-disk kernel
cache where the parent's evaluator reads them: a WFE model's kernels use both cores there
too (not with a memory-only cache, whose kernels stay in their process).
"""
from __future__ import annotations

import io
import logging
import math
import multiprocessing
import pickle
import queue
import signal
import time

from railfem.diagnosis import effects as library
from railfem.diagnosis.problem import Problem
from railfem.identify import discrepancy as model_form
from railfem.track import kernelcache

log = logging.getLogger(__name__)

_STATE: dict = {}  # what forked workers inherit: fn, tasks, shared objects, log collector


class Collector(logging.Handler):
    """A worker's log handler: every record once (several loggers of its chain may carry
    it), made picklable (message formatted, exception as text)."""

    def __init__(self):
        super().__init__(level=logging.NOTSET)
        self.records: list = []
        self.seen: set = set()

    def emit(self, record):
        if id(record) in self.seen:
            return
        self.seen.add(id(record))
        record.msg, record.args = record.getMessage(), None
        if record.exc_info:
            record.exc_text = logging.Formatter().formatException(record.exc_info)
            record.exc_info = None
        record.stack_info = None
        self.records.append(record)

    def take(self) -> list:
        out, self.records, self.seen = self.records, [], set()
        return out


def _loggers() -> list:
    return [logging.getLogger()] + [lg for lg in logging.Logger.manager.loggerDict.values()
                                    if isinstance(lg, logging.Logger)]


def _init() -> None:
    """A worker: SIGINT ignored and SIGTERM the default (the parent ends the pool; a
    handler inherited from the command line would unwind it with a traceback), BLAS on
    one thread, every logging handler replaced by the collector (its records go to the
    parent)."""
    from threadpoolctl import threadpool_limits

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _STATE["limits"] = threadpool_limits(1)  # kept for the worker's lifetime
    collector = _STATE["collector"] = Collector()
    for lg in _loggers():
        if lg.handlers:
            for h in list(lg.handlers):
                lg.removeHandler(h)
            lg.addHandler(collector)


def shared_ids(objects) -> dict:
    """{id: reference} of the objects sent by reference: ``objects`` (name -> object)
    and the effects of the library (by name)."""
    out = {id(o): ("object", name) for name, o in objects.items()
           if o is not None and not isinstance(o, (bool, int, float, str))}
    for n in library.names():
        out.setdefault(id(library.get(n)), ("effect", n))
    return out


def dumps(value, refs: dict) -> bytes:
    """``value`` pickled with the objects of ``refs`` ({id: reference}) by reference."""
    buf = io.BytesIO()
    p = pickle.Pickler(buf, protocol=pickle.HIGHEST_PROTOCOL)
    p.persistent_id = lambda o: refs.get(id(o))
    p.dump(value)
    return buf.getvalue()


def loads(data: bytes, objects: dict):
    """The inverse of dumps in the parent: references resolved to ``objects`` (name ->
    object) and the library's effects."""
    u = pickle.Unpickler(io.BytesIO(data))

    def resolve(ref):
        kind, name = ref
        return objects[name] if kind == "object" else library.get(name)

    u.persistent_load = resolve
    return u.load()


class TaskError(Exception):
    """An exception of a worker's item that does not pickle, as its class's name and its
    message (``named`` gives it back a class of that name, in the parent)."""

    def __init__(self, name: str, message: str):
        super().__init__(name, message)
        self.name, self.message = name, message

    def __str__(self) -> str:
        return self.message

    def named(self) -> TaskError:
        return type(self.name, (TaskError,), {})(self.name, self.message)


def portable(exc: BaseException) -> BaseException:
    """``exc`` if it pickles and unpickles, else a TaskError with its name and message."""
    try:
        pickle.loads(pickle.dumps(exc))
        return exc
    except Exception:  # noqa: BLE001 - any exception that does not travel
        return TaskError(type(exc).__name__, str(exc))


def _group(k: int) -> None:
    """In a worker: the items of group k run in turn, each one's (index, pickled (ok,
    value), log records) put on the queue as soon as it is done."""
    fn, items, refs = _STATE["fn"], _STATE["items"], _STATE["refs"]
    for i in _STATE["groups"][k]:
        try:
            ok, value = True, fn(items[i])
        except Exception as exc:  # noqa: BLE001 - the parent reports it (a failed candidate)
            ok, value = False, portable(exc)
        try:
            payload = dumps((ok, value), refs)
        except Exception as exc:  # noqa: BLE001 - a result that cannot travel is a failure
            payload = dumps((False, portable(exc)), refs)
        _STATE["queue"].put((i, payload, _STATE["collector"].take()))


def serial(fn, items):
    """(index, ok, value) of fn(item) for every item, here, in turn."""
    for i, t in enumerate(items):
        try:
            value = fn(t)
        except Exception as exc:  # noqa: BLE001 - the caller reports it
            yield i, False, exc
            continue
        yield i, True, value


def run(fn, items, workers: int, shared: dict, groups=None, quiet: bool = False):
    """Yield (index, ok, value) of ``fn(item)`` for every item (value: the result, or the
    exception raised when ok is False): here in the order of ``items`` when workers <= 1
    (or in a daemonic process, e.g. a process pool's worker, which has no children), else
    in ``workers`` forked processes (see the module docstring) as each is done.
    ``groups``: lists of item indices, each run in turn in one worker (items sharing
    kernels), started in the order given (the costliest first); default one per item.
    ``shared``: {name: object} the parent holds and results refer to (by reference);
    ``quiet``: the workers' records below WARNING dropped (work the parent logs itself)."""
    items = list(items)
    groups = [list(g) for g in (groups or [[i] for i in range(len(items))])]
    n = min(int(workers), len(groups))
    if (n <= 1 or "fork" not in multiprocessing.get_all_start_methods()
            or multiprocessing.current_process().daemon):  # a pool's worker: no children
        yield from serial(fn, items)
        return
    objects = dict(shared)
    ctx = multiprocessing.get_context("fork")
    _STATE.update(fn=fn, items=items, groups=groups, refs=shared_ids(objects),
                  queue=ctx.Queue())
    before = set(multiprocessing.active_children())
    pool = ctx.Pool(n, initializer=_init)
    mine = [p for p in multiprocessing.active_children() if p not in before]
    try:
        result = pool.map_async(_group, range(len(groups)), chunksize=1)
        for _ in range(sum(len(g) for g in groups)):
            i, payload, records = receive(result, mine)
            for r in records:
                if not quiet or r.levelno >= logging.WARNING:
                    logging.getLogger(r.name).handle(r)
            ok, value = loads(payload, objects)
            if isinstance(value, TaskError):
                value = value.named()
            yield i, ok, value
    finally:
        pool.terminate()
        pool.join()
        for key in ("fn", "items", "groups", "refs", "queue"):
            _STATE.pop(key, None)


def receive(result, workers):
    """The next item's message from the queue; raises when the pool failed (an error
    outside the items' own, or a worker process that died: its group would never
    report)."""
    while True:
        try:
            return _STATE["queue"].get(timeout=0.5)
        except queue.Empty:
            pass
        if result.ready() and not result.successful():
            result.get()  # raises the pool's error
        dead = [p for p in workers if p.exitcode not in (None, 0)]
        if dead:
            raise RuntimeError(f"a diagnosis worker process ended with exit code "
                               f"{dead[0].exitcode}")


def prefetch(ev, workers: int, thunks) -> None:
    """Kernels the next serial step of the diagnosis will ask for, computed ahead in
    ``workers`` processes (``thunks``: functions of no argument that build them through
    the evaluator ``ev``, e.g. base_kernels) into the on-disk kernel cache, where the
    parent's evaluator reads them. Only with a cache folder (a memory-only store is each
    process's own); an error is left to the parent's own evaluation."""
    if workers <= 1 or len(thunks) < 2 or kernelcache.resolve(ev.cache).directory is None:
        return
    t0 = time.perf_counter()
    for _ in run(lambda f: f(), thunks, workers, {}, quiet=True):
        pass
    log.info("diagnosis: %d evaluations' kernels built ahead in %d processes (%.1f s)",
             len(thunks), min(workers, len(thunks)), time.perf_counter() - t0)


def evaluation(ev, data, spec, effects=(), grid=None, x=None, once: bool = False):
    """A function that evaluates the model ``spec`` + ``effects`` (grid values ``grid``)
    at vector ``x`` on every record of ``data`` (``once``: each record by
    Evaluator.receptance_once, as a discrepancy variant), building its kernels."""
    def run_it():
        if once:
            for r in data.records:
                ev.receptance_once(spec, r)
        else:
            Problem(data=data, evaluator=ev, spec=spec, effects=effects,
                    grid=grid).predict(x)
    return run_it


def base_kernels(ev, data, spec_b, x0, discrepancy, profile_final: bool) -> list:
    """What the base step of a WFE diagnosis evaluates after the start fit, as
    evaluations for prefetch: the discrepancy's variants of the base at x0 ('ensemble':
    railfem.diagnosis.problem.ensemble) and the base at the rail-loss kernels 0.1 decades
    either side (its interval, railfem.diagnosis.rail_loss.eta_r_interval; the support
    effects' short profile)."""
    if not spec_b.kind.is_wfe:
        return []
    spec_x = Problem(data=data, evaluator=ev, spec=spec_b).model.base_spec(x0)
    out = [evaluation(ev, data, v, once=True) for _, v in model_form.variants(spec_x)] \
        if discrepancy == "ensemble" else []
    e0 = math.log10(spec_b.rail.eta)
    return out + ([evaluation(ev, data, spec_b.replace(eta_r=10 ** round(e0 + d, 6)), x=x0)
                   for d in (-0.1, 0.1)] if profile_final else [])


def kernel_groups(cands, wfe: bool) -> list[list[int]]:
    """Candidates (indices) that share kernels, each group run in turn in one worker (the
    deviating supports' Woodbury form, the shifted geometries' banks, a WFE model's
    support effects' rail-loss lattice (``wfe``): a beam kernel costs less than the wait), the
    costliest group first (cost_hint)."""
    keys: dict = {}
    for i, e in enumerate(cands):
        key = ("deviations" if "deviations" in e.needs else "geometry"
               if e.kind == "geometry" else "support" if wfe and library.support_only(e) else i)
        keys.setdefault(key, []).append(i)
    groups = list(keys.values())
    return sorted(groups, key=lambda g: -(max(cost_hint(cands[i]) for i in g)
                                          + 0.1 * (len(g) - 1)))


def cost_hint(e) -> float:
    """A rough rank of an effect's screening cost (the kernels it builds), to start the
    costliest first."""
    if "wfe" in e.needs:
        return 8.0  # a rail section per grid value
    if e.kind == "spec" and set(e.grid) - {"index", "spread"}:
        return 4.0  # a kernel per grid value (pad length)
    if "deviations" in e.needs:
        return 3.0 if e.prior is not None else 2.0
    if e.kind == "geometry":
        return 2.5  # a kernel of every registered shift
    if library.support_only(e):
        return 2.0  # the rail-loss kernels the base step has not built
    return 0.0 if e.kind == "measurement" else 1.0
