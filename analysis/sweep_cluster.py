"""Where a sweep's points run when not in this process: a Dask client on a local cluster (started
and stopped here) or on a scheduler someone started (``--scheduler tcp://host:8786``), and the
signals around it.

A scheduler's address is checked before any connection (:func:`check_scheduler_address`: a
transport this machine has, a host and a port, TLS certificates for ``tls://``), the connection
waits at most :data:`CONNECT_TIMEOUT_S`, and a scheduler lost in the middle of a sweep stops it
(:func:`raise_if_scheduler_lost`): each is one ``ValueError`` naming the address.

The command line starts the local cluster's worker server first (:func:`start_worker_server`):
its workers are forked from a process that has their imports done, which it did while the
command imported and checked the points.  A Ctrl-C while the local cluster starts waits until
it is up, then closes it (:class:`dask_client`); the worker server says nothing of a Ctrl-C or
of its command being gone (:func:`_quiet_interrupt`).  Nothing here imports Dask until a
cluster is asked for.
"""

from __future__ import annotations

import atexit
import contextlib
import json
import logging
import os
import sys

#: What a point imports in its worker process, its first point paying for them otherwise (about
#: 0.5 s: Dask, MuJoCo, the sensor's modules).
#: The worker server imports them once, before any worker exists (:func:`start_worker_server`).
WORKER_MODULES = (
    "piezotip.analysis.sweep_cluster",  # first: in the server it sets the import path (see below)
    "piezotip.analysis.sweep",  # where the workers' task, run_point, lives
    "distributed",
    "tqdm",
    "piezotip.analysis.runner",
    "piezotip.analysis.run_report",
    "piezotip.cosim.loop",
)

#: What Dask's nanny puts in the environment before it starts a worker process (its
#: ``distributed.nanny.pre-spawn-environ`` defaults and its hash seed).  A worker forked from the
#: worker server has the server's environment, so the server starts with these; a value already
#: in this process's environment wins, as with Dask.
WORKER_ENV = {
    "MALLOC_TRIM_THRESHOLD_": "65536",
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "PYTHONHASHSEED": "6640",
}

_worker_server = False

#: Set in the worker server's environment alone (this process's id and import path, as JSON):
#: the server's import of this module sees it (below) and takes it out (the workers forked later
#: do not have it).
_SERVER_FLAG = "PIEZOTIP_WORKER_SERVER_OF"


def _exit_now() -> None:
    """The worker server's exit (when the process that started it is gone; the workers are
    gone too, each watches that process): at once, without the clean-up of an interpreter
    that has Dask and MuJoCo loaded (0.15 s, which the command's caller waits for: the server
    holds its output pipes too)."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (AttributeError, OSError, ValueError):
            pass
    os._exit(0)


def _in_worker_server() -> bool:
    """Whether this process is the worker server that this module's parent process started."""
    try:
        parent = json.loads(os.environ.pop(_SERVER_FLAG, "null"))
    except ValueError:
        return False
    if not isinstance(parent, dict) or parent.get("pid") != os.getppid():
        return False
    # Python 3.11's forkserver ignores the import path it is given: the parent's, as a spawned
    # worker has it (the server's own would put the current folder first), before any other import.
    sys.path[:] = parent["path"]
    global _command_pid
    _command_pid = parent["pid"]
    atexit.register(_exit_now)
    # A Ctrl-C while it imports, or a worker it forks failing because the command is gone:
    # the command says "interrupted", once.  The forkserver reports a fork's error through
    # sys.excepthook.
    sys.excepthook = _quiet_interrupt
    return True


#: In the worker server (and the workers it forks): the process id of the command that started it.
_command_pid: int | None = None


def _command_gone() -> bool:
    """Whether the command that started this worker server has exited."""
    if _command_pid is None:
        return False
    try:
        os.kill(_command_pid, 0)
    except ProcessLookupError:
        return True
    except OSError:  # it exists (and belongs to another user: not ours, but alive)
        return False
    return False


def _quiet_interrupt(kind, value, tb) -> None:
    """The worker server's last word on an exception: none for Ctrl-C or once the command is
    gone (a worker forked as it was interrupted cannot reach it), the usual otherwise."""
    if not (issubclass(kind, KeyboardInterrupt) or _command_gone()):
        sys.__excepthook__(kind, value, tb)


_in_worker_server()


def start_worker_server() -> bool:
    """Start, in the background, the process this process's local clusters fork their workers
    from (multiprocessing's forkserver, :data:`WORKER_MODULES` imported), and return whether
    they will (False where there is no forkserver: they then start workers as Dask does, each
    a fresh interpreter that imports everything itself).

    Call it as early as possible (the command line does, before its own imports and checks):
    the server's imports then run beside this process's work, and each worker starts in
    milliseconds, imports done, instead of a second; it also exits without an interpreter's
    clean-up.  The server is single-threaded when it forks (the point of a forkserver: this
    process has threads, a fork of it could deadlock); it exits when this process does.
    Without this call the local cluster spawns its workers (Dask's default), which leaves
    multiprocessing's global forkserver alone for a program that uses the API."""
    global _worker_server
    if _worker_server:
        return True
    import multiprocessing
    from multiprocessing import forkserver

    if "forkserver" not in multiprocessing.get_all_start_methods():
        return False
    multiprocessing.get_context("forkserver").set_forkserver_preload(list(WORKER_MODULES))
    parent = json.dumps({"pid": os.getpid(), "path": sys.path})
    server_env = {**{key: os.environ.get(key, value) for key, value in WORKER_ENV.items()}, _SERVER_FLAG: parent}
    saved = {key: os.environ.get(key) for key in server_env}
    os.environ.update(server_env)
    try:
        forkserver.ensure_running()  # starts it and returns; the server imports while we go on
    except OSError:
        return False
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
    _worker_server = True
    return True


class _interrupts_deferred:
    """Inside, Ctrl-C (SIGINT) and SIGTERM are held: the first raises on leaving the block (its
    exception, piezotip.interrupts.interruption: exit 130, or 143 for SIGTERM), not in the middle
    of it, unless ``pending`` (an exception already on its way out of the code around: the signal
    then adds nothing).  Only in the main thread, for a signal whose handler is Python's own or
    piezotip's (with a handler a program set, nothing changes)."""

    def __init__(self, pending: bool = False) -> None:
        self.pending = pending

    def __enter__(self):
        import signal

        from piezotip.runtime.interrupts import in_main_thread, replaceable

        self.caught, self.previous = None, {}
        if in_main_thread():
            for signum in (signal.SIGINT, signal.SIGTERM):
                if replaceable(signum, signal.getsignal(signum)):
                    self.previous[signum] = signal.signal(signum, self._hold)
        return self

    def _hold(self, signum, frame) -> None:
        from piezotip.runtime.interrupts import note

        note(signum)
        if self.caught is None:
            self.caught = signum

    def __exit__(self, kind, value, tb) -> None:
        import signal

        from piezotip.runtime.interrupts import interruption

        for signum, previous in self.previous.items():
            signal.signal(signum, previous)
        if self.caught is not None and kind is None and not self.pending:
            raise interruption(self.caught)


#: Dask settings of the local cluster, each as (Dask's default, this cluster's): the servers'
#: periodic wake-ups, which in a worker take the GIL from the run in its thread (the event
#: loop's lag measured every 20 ms, a statistical profiler sampling every 10 ms, the system
#: monitor's resource readings every 0.5 s), feed only Dask's dashboard and its "event loop
#: was unresponsive" warning; this cluster has neither.  Measured on the 96-grasp sweep of
#: ``bench --throughput``, 2 workers, three alternating pairs: 3-5 % less wall time, the runs
#: 5-6 % less.  A setting a user has changed from Dask's default stays theirs.
LOCAL_CLUSTER_CONFIG = {
    "distributed.admin.tick.interval": ("20ms", "1s"),
    "distributed.worker.profile.enabled": (True, False),
    "distributed.admin.system-monitor.interval": ("500ms", "5s"),
}


def local_cluster_config() -> dict:
    """The settings of :data:`LOCAL_CLUSTER_CONFIG` to set now: those still at Dask's default,
    and the multiprocessing method (a fork from the worker server, when this process started
    one and the method is Dask's default, "spawn")."""
    import dask
    import distributed  # noqa: F401  (its defaults join dask.config on import)

    config = {key: ours for key, (default, ours) in LOCAL_CLUSTER_CONFIG.items() if dask.config.get(key, None) == default}
    method = "distributed.worker.multiprocessing-method"
    if _worker_server and dask.config.get(method) == "spawn":
        config[method] = "forkserver"
    return config


#: How long a client waits for the scheduler at ``--scheduler ADDRESS`` to answer, s: Dask
#: retries a refused connection until then (a scheduler may be starting), and a server that
#: accepted the connection gets as long again to answer as a Dask scheduler (Dask itself would
#: wait for that answer for ever: :func:`_handshake`).
CONNECT_TIMEOUT_S = 10.0
#: Dask's reason for the futures it cancels when its client loses the scheduler.
_CONNECTION_LOST = "scheduler-connection-lost"


class SchedulerLost(ValueError):
    """The scheduler went away in the middle of a sweep (the command line's exit 2: the
    environment, not a point, failed)."""


def check_scheduler_address(address: str) -> None:
    """A ValueError naming ``--scheduler ADDRESS`` and what is wrong with it, before any
    connection is tried; nothing if a client here can try to reach it.

    Refused: an address that is not text; ``inproc://`` (Dask's in-process transport: it never
    leaves the process that made it, and a sweep's scheduler is in another); a scheme Dask does
    not know, or whose transport is not installed (``ucx://`` needs ``distributed-ucxx``); a
    missing host, a missing port or one outside 1..65535; ``tls://`` and ``wss://`` without
    this client's TLS certificates in Dask's configuration (``distributed.comm.tls.*``).
    """
    from distributed.comm import registry
    from distributed.comm.addressing import parse_address, parse_host_port

    if not isinstance(address, str) or not address.strip():
        raise ValueError(f"--scheduler needs a Dask scheduler's address, e.g. tcp://HOST:8786; got {address!r}")
    given = f"--scheduler {address}"
    scheme, location = parse_address(address)  # no scheme: tcp, as Dask takes it
    if scheme == "inproc":
        raise ValueError(
            f"{given}: an inproc:// address is Dask's in-process transport, which never leaves the process that made it; "
            "a sweep's scheduler runs in another: give its tcp://HOST:PORT"
        )
    try:
        backend = registry.get_backend(scheme)
    except ValueError:
        known = ", ".join(f"{name}://" for name in sorted(registry.backends) if name != "inproc")
        raise ValueError(f"{given}: unknown address scheme {scheme!r} (Dask's are {known}; e.g. tcp://HOST:8786)") from None
    try:
        backend.get_connector()
    except Exception as err:  # Dask's UCX stub: an abstract connector (TypeError); a plugin whose import fails
        if scheme == "ucx":
            why = "Distributed's UCX transport is a separate package, distributed-ucxx, which is not installed here"
        else:
            text = str(err).strip()
            why = f"Dask cannot open a {scheme}:// connection here ({type(err).__name__}: {text.splitlines()[0][:200] if text else ''})"
        raise ValueError(f"{given}: {why}; install it, or give the scheduler's tcp:// address") from None
    try:
        host, port = parse_host_port(location)
    except ValueError:
        raise ValueError(f"{given}: needs a host and a port, {scheme}://HOST:PORT (a Dask scheduler listens on 8786 by default)") from None
    if not host:
        raise ValueError(f"{given}: needs a host before the port, {scheme}://HOST:{port}")
    if not 1 <= port <= 65535:
        raise ValueError(f"{given}: port {port} is not a TCP port (1..65535)")
    if scheme in ("tls", "wss"):
        from distributed.security import Security

        try:
            context = Security().get_connection_args("client").get("ssl_context")
        except (OSError, ValueError) as err:  # a configured certificate that cannot be read
            raise ValueError(f"{given}: Dask's TLS settings (distributed.comm.tls.*) cannot be used: {err}") from None
        if context is None:  # Dask's connector would fail with a TypeError
            raise ValueError(
                f"{given}: a {scheme}:// scheduler needs this client's TLS certificates, and Dask's configuration names none "
                "(distributed.comm.tls.ca-file, .client.cert and .client.key; e.g. DASK_DISTRIBUTED__COMM__TLS__CA_FILE=...)"
            )


def _handshake(address: str, timeout_s: float) -> None:
    """Connect to ``address`` as a Dask client does and close again, or a ValueError naming it.

    Dask's ``connect`` retries for ``timeout_s`` and then waits for the other end's handshake
    without a limit: a server that is not a Dask scheduler (the dashboard's port, a web server)
    kept ``Client(address, timeout=...)`` waiting for ever.  Here the whole exchange is bounded
    (``2 timeout_s``), in a thread of its own with its own event loop (a caller's loop, as in a
    notebook, is left alone).
    """
    import asyncio
    import threading

    from distributed.comm import connect
    from distributed.security import Security

    connection_args = Security().get_connection_args("client")
    outcome: dict = {}

    async def exchange() -> None:
        comm = await connect(address, timeout=timeout_s, **connection_args)
        try:  # the scheduler answered: leave as a client does (it would log a connection dropped unannounced)
            await comm.write({"op": "close", "reply": False})
        except OSError:
            pass
        finally:
            comm.abort()

    def run() -> None:
        try:
            asyncio.run(asyncio.wait_for(exchange(), 2.0 * timeout_s))
        except BaseException as err:  # handed to the calling thread
            outcome["error"] = err

    thread = threading.Thread(target=run, name="piezotip-scheduler-handshake", daemon=True)
    thread.start()
    thread.join()
    err = outcome.get("error")
    if err is None:
        return
    given = f"--scheduler {address}"
    if isinstance(err, TimeoutError):  # wait_for's: connected, no handshake (Dask's own gives up with a plain OSError)
        raise ValueError(
            f"{given}: something accepts connections there but did not answer as a Dask scheduler within {2.0 * timeout_s:g} s "
            "(a scheduler listens on 8786 by default; 8787 is its dashboard)"
        ) from None
    if isinstance(err, OSError):
        raise ValueError(f"{given}: cannot reach a Dask scheduler there ({' '.join(str(err).split()) or type(err).__name__})") from None
    raise err


def raise_if_scheduler_lost(client, err: BaseException, address: str | None, finished: int, total: int, journal) -> None:
    """SchedulerLost if ``err`` (a future's) or ``client`` says the scheduler is gone, else nothing.

    When a client loses its scheduler, Dask cancels every future it holds: none of the points
    left failed, and none is a row (journaled as an error, each would read as the point's own
    failure).  ``finished`` of ``total`` points had finished in this sweep, journaled in
    ``journal`` (None: nowhere), from which the same command resumes.
    """
    if getattr(err, "reason", None) != _CONNECTION_LOST and getattr(client, "status", "running") == "running":
        return
    where = f"--scheduler {address}" if address is not None else "the local Dask cluster"
    done = f"{finished} of {total} points finished" + (f" (journaled in {journal})" if finished and journal is not None else "")
    then = f"the same command resumes with the other {total - finished}" if journal is not None else "nothing was kept (no --out)"
    raise SchedulerLost(f"{where}: lost the connection to the Dask scheduler with {done}; {then}")


@contextlib.contextmanager
def _dask_logs_silenced():
    """Dask's own log lines held back: a client closed after it lost its scheduler logs its
    cancelled reconnection as an ERROR with a 33-line asyncio traceback, which
    :class:`SchedulerLost`'s one line says already."""
    names = ["distributed", *(n for n in logging.root.manager.loggerDict if n.startswith("distributed."))]
    handlers = {h for n in names for h in logging.getLogger(n).handlers}
    levels = {h: h.level for h in handlers}
    for handler in handlers:
        handler.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        for handler, level in levels.items():
            handler.setLevel(level)


class dask_client:
    """A Dask client on a local cluster of ``workers`` processes (closed on exit), or on the
    scheduler at ``address``.  The local cluster's workers are forked from the worker server
    when this process started one (:func:`start_worker_server`), with the settings of
    :func:`local_cluster_config` (held while the cluster lives: its workers get them from their
    nanny, and a worker the nanny restarts starts the same way)."""

    def __init__(self, workers: int | None, address: str | None) -> None:
        self.workers, self.address = workers, address
        self.cluster = self.client = self.config = None

    def __enter__(self):
        import dask
        from dask.distributed import Client, LocalCluster

        if self.address is not None:
            check_scheduler_address(self.address)
            _handshake(self.address, CONNECT_TIMEOUT_S)
            try:
                self.client = Client(self.address, timeout=f"{CONNECT_TIMEOUT_S}s")
            except OSError as err:
                raise ValueError(f"--scheduler {self.address}: cannot reach a Dask scheduler there ({err})") from None
            return self.client
        n = self.workers if self.workers is not None else (os.cpu_count() or 1)
        self.config = dask.config.set(local_cluster_config())
        try:
            # A cluster interrupted half-started cannot be closed (Dask's own close at exit then
            # fails with a traceback): a Ctrl-C waits until it is up (well under a second), then
            # closes it.
            with _interrupts_deferred():
                # One thread per process: the loop holds the GIL; processes run side by side.
                self.cluster = LocalCluster(
                    n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=50, memory_limit=0
                )
                self.client = Client(self.cluster)
        except BaseException as err:
            self.__exit__(type(err), err, None)
            raise
        return self.client

    def __exit__(self, kind, value, tb) -> None:
        # A signal while the cluster closes waits until it is closed: a close cut short leaves
        # Dask's own close at exit a half-closed cluster (a traceback, and the process killed by
        # a signal that comes then).  It is raised after, unless an exception (the first signal's)
        # is already leaving.
        try:
            with _interrupts_deferred(pending=kind is not None):
                if self.client is not None:
                    lost = getattr(self.client, "status", "running") != "running"  # its scheduler gone: raise_if_scheduler_lost said so
                    with _dask_logs_silenced() if lost else contextlib.nullcontext():
                        self.client.close()
                if self.cluster is not None:
                    self.cluster.close()
        finally:
            if self.config is not None:
                self.config.__exit__(None, None, None)
                self.config = None
