"""The study's web app: a FastAPI app on uvicorn that serves the page and its JSON API.

Security follows the Jupyter server's model: it binds the loopback interface by default, every API
request and the page itself need the random token printed in the start-up URL (``?token=``, or the
``X-Study-Token`` header), and requests with a foreign ``Host`` header (DNS rebinding) or a cross-site
``Origin`` are refused. Bodies are JSON objects of at most :data:`MAX_BODY_BYTES`.

API (all under ``/api``, JSON in and out; errors are ``{"error": "..."}`` with a 4xx status):

* ``GET /api/study``: body, participants and where each one is;
* ``GET /api/questionnaire``: the questionnaire items;
* ``GET /api/participants/{id}/state``: what the page shows;
* ``POST /api/participants/{id}/start``: start the next trial;
* ``POST /api/participants/{id}/label`` ``{"query", "x", "y", "response_seconds"}``: a click;
* ``POST /api/participants/{id}/next``: after a click that ended an episode, close it (the learner's
  update) and open the next maze; the page sends it while it animates the last walk;
* ``POST /api/participants/{id}/questionnaire`` ``{"trial", "ratings", "comment"}``;
* ``POST /api/participants/{id}/pause`` ``{"paused": true|false}``;
* ``GET /api/participants/{id}/frame.png``: the ant's camera view, where OpenGL rendering works.
"""

from __future__ import annotations

import contextlib
import hmac
import json
import secrets
import socket
import sys
import threading
import time
from collections.abc import Awaitable, Callable, Iterator, Sequence
from importlib import resources
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

from fastapi import FastAPI, Request
from fastapi.responses import HTMLResponse, JSONResponse, Response
from fastapi.staticfiles import StaticFiles
from starlette.concurrency import run_in_threadpool

from antmaze_hirl.study.camera import CameraUnavailable
from antmaze_hirl.study.questionnaire import SCALE_MAX, TLX_ITEMS
from antmaze_hirl.study.session import BadInput, ProtocolError
from antmaze_hirl.study.store import Study, UnknownParticipant

MAX_BODY_BYTES = 16_384
"""Largest request body accepted (a click or a questionnaire is far smaller)."""

LOOPBACK_HOSTS = ("127.0.0.1", "localhost", "::1")
TOKEN_HEADER = "X-Study-Token"


def _reject_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a number JSON allows")


def parse_json_object(body: bytes) -> dict[str, Any]:
    """A request body as a JSON object.

    Raises:
        BadInput: If the body is too large, not UTF-8 JSON (``NaN``/``Infinity`` included), or not an object.
    """
    if len(body) > MAX_BODY_BYTES:
        raise BadInput(f"request body of {len(body)} bytes is larger than {MAX_BODY_BYTES}")
    try:
        payload = json.loads(body.decode("utf-8"), parse_constant=_reject_constant)
    except (UnicodeDecodeError, ValueError) as error:
        raise BadInput(f"request body is not valid JSON: {error}") from error
    if not isinstance(payload, dict):
        raise BadInput(f"request body must be a JSON object, got {type(payload).__name__}")
    return payload


def _host_name(netloc: str) -> str:
    # "127.0.0.1:8765" -> "127.0.0.1", "[::1]:8765" -> "::1", "localhost" -> "localhost"
    return (urlsplit(f"//{netloc}").hostname or "").lower()


def create_app(study: Study, *, token: str, allowed_hosts: Sequence[str] = LOOPBACK_HOSTS) -> Any:
    """The FastAPI app serving ``study``.

    Args:
        study: The opened study folder.
        token: Secret every request to the page or the API must carry.
        allowed_hosts: Host names accepted in the ``Host`` header (and as same-site ``Origin``).
    """
    if not token:
        raise ValueError("the study server needs a non-empty token")
    hosts = {host.lower().strip("[]") for host in allowed_hosts}
    static = resources.files("antmaze_hirl.study") / "static"
    app = FastAPI(title="antmaze_hirl study", docs_url=None, redoc_url=None, openapi_url=None)
    app.state.study = study

    def error(status: int, message: str) -> Any:
        return JSONResponse({"error": message}, status_code=status)

    @app.middleware("http")
    async def guard(request: Request, call_next: Callable[[Request], Awaitable[Any]]) -> Any:
        host = request.headers.get("host", "")
        if _host_name(host) not in hosts:
            return error(403, f"Host header {host!r} is not allowed (allowed: {sorted(hosts)})")
        origin = request.headers.get("origin")
        if origin is not None and urlsplit(origin).netloc.lower() != host.lower():
            return error(403, f"cross-site request from Origin {origin!r} refused")
        path = request.url.path
        if path == "/" or path.startswith("/api/"):
            given = request.headers.get(TOKEN_HEADER) or request.query_params.get("token") or ""
            if not hmac.compare_digest(given.encode(), token.encode()):
                if path == "/":
                    return HTMLResponse(
                        "<h1>403</h1><p>Open the study with the URL the server printed (it ends with ?token=...).</p>",
                        status_code=403,
                    )
                return error(403, "missing or wrong token: use the URL the server printed")
        length = request.headers.get("content-length")
        if length is not None and (not length.isdigit() or int(length) > MAX_BODY_BYTES):
            return error(413, f"request body of {length} bytes is larger than {MAX_BODY_BYTES}")
        started = time.perf_counter()
        try:
            response = await call_next(request)
        except BadInput as bad:
            return error(400, str(bad))
        except ProtocolError as conflict:
            return error(409, str(conflict))
        except UnknownParticipant as unknown:
            return error(404, str(unknown))
        # The server's own time, apart from the network and the browser (benchmarks/study_latency.py reads it).
        response.headers["Server-Timing"] = f"app;dur={(time.perf_counter() - started) * 1000:.1f}"
        return response

    async def body_of(request: Request) -> dict[str, Any]:
        return parse_json_object(await request.body())

    @app.get("/")
    async def page() -> Any:
        return HTMLResponse((static / "index.html").read_text(encoding="utf-8"))

    @app.get("/api/study")
    async def study_overview() -> Any:
        # From the saved progress: the participant picker must not build every participant's simulators.
        participants = []
        for participant in study.plan.participants:
            index, phase = study.progress(participant.id)
            number = index + 1 if index < len(participant.trials) else None  # None once every trial is done
            participants.append({"id": participant.id, "phase": phase, "trial": number})
        return {"body": study.plan.body, "participants": participants}

    @app.get("/api/questionnaire")
    async def questionnaire() -> Any:
        items = [
            {
                "key": item.key,
                "title": item.title,
                "question": item.question,
                "low": item.low_anchor,
                "high": item.high_anchor,
                "points": SCALE_MAX,
            }
            for item in TLX_ITEMS
        ]
        return {"items": items}

    @app.get("/api/participants/{participant_id}/state")
    async def state(participant_id: str) -> Any:
        return await run_in_threadpool(study.session(participant_id).state)

    @app.post("/api/participants/{participant_id}/start")
    async def start(participant_id: str, request: Request) -> Any:
        await body_of(request)
        return await run_in_threadpool(study.session(participant_id).start_trial)

    @app.post("/api/participants/{participant_id}/label")
    async def label(participant_id: str, request: Request) -> Any:
        payload = await body_of(request)
        unknown = sorted(set(payload) - {"query", "x", "y", "response_seconds"})
        if unknown:
            raise BadInput(f"unknown field(s) {unknown} in a click")
        session = study.session(participant_id)
        return await run_in_threadpool(
            session.label, payload.get("query"), payload.get("x"), payload.get("y"), payload.get("response_seconds")
        )

    @app.post("/api/participants/{participant_id}/next")
    async def next_episode(participant_id: str, request: Request) -> Any:
        await body_of(request)
        return await run_in_threadpool(study.session(participant_id).next_episode)

    @app.post("/api/participants/{participant_id}/questionnaire")
    async def answers(participant_id: str, request: Request) -> Any:
        payload = await body_of(request)
        trial = payload.pop("trial", None)
        return await run_in_threadpool(study.session(participant_id).submit_questionnaire, trial, payload)

    @app.post("/api/participants/{participant_id}/pause")
    async def pause(participant_id: str, request: Request) -> Any:
        payload = await body_of(request)
        return await run_in_threadpool(study.session(participant_id).set_paused, payload.get("paused"))

    @app.get("/api/participants/{participant_id}/frame.png")
    async def frame(participant_id: str) -> Any:
        session = study.session(participant_id)
        try:
            png = await run_in_threadpool(session.camera_frame)
        except CameraUnavailable as missing:
            return error(404, str(missing))
        return Response(png, media_type="image/png", headers={"Cache-Control": "no-store"})

    app.mount("/static", StaticFiles(directory=str(static)), name="static")
    return app


def new_token() -> str:
    """A random URL-safe token (Jupyter-style)."""
    return secrets.token_urlsafe(24)


def bind_socket(host: str, port: int) -> socket.socket:
    """A listening TCP socket on ``host:port`` (port 0: a free one), handed to uvicorn so no other process races for it.

    Raises:
        OSError: If the address is taken or invalid (names it).
    """
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
    except OSError as error:
        sock.close()
        raise OSError(f"cannot listen on {host}:{port}: {error.strerror}") from error
    sock.listen(128)
    sock.set_inheritable(True)
    return sock


def study_url(host: str, port: int, token: str) -> str:
    """The URL a participant's browser opens."""
    shown = f"[{host}]" if ":" in host else host
    return f"http://{shown}:{port}/?token={token}"


class StudyServer:
    """Runs the app on uvicorn in a background thread (for ``study simulate``, tests and benchmarks).

    Args:
        study_dir: The study folder.
        host: Interface to bind (loopback by default).
        port: TCP port; 0 picks a free one.
        token: The token; a random one by default.
    """

    def __init__(self, study_dir: str | Path, *, host: str = "127.0.0.1", port: int = 0, token: str | None = None):
        import uvicorn

        self.study = Study(study_dir)
        self.token = token or new_token()
        self.host = host
        self.socket = bind_socket(host, port)
        self.port = int(self.socket.getsockname()[1])
        app = create_app(self.study, token=self.token, allowed_hosts=allowed_hosts_for(host))
        config = uvicorn.Config(app, log_level="warning", lifespan="off")
        self._server = uvicorn.Server(config)
        self._thread = threading.Thread(target=self._server.run, kwargs={"sockets": [self.socket]}, daemon=True)

    @property
    def url(self) -> str:
        """The participant's URL, token included."""
        return study_url(self.host, self.port, self.token)

    @property
    def base_url(self) -> str:
        """``http://host:port`` without the token."""
        return self.url.split("/?", 1)[0]

    def start(self) -> StudyServer:
        """Starts serving; returns once uvicorn accepts connections."""
        self._thread.start()
        while not self._server.started:
            if not self._thread.is_alive():
                raise RuntimeError("the study server stopped during start-up")
            self._thread.join(0.02)
        return self

    def stop(self) -> None:
        """Stops serving and releases the simulators."""
        self._server.should_exit = True
        self._thread.join(10)
        self.socket.close()
        self.study.close()

    @contextlib.contextmanager
    def running(self) -> Iterator[StudyServer]:
        """``with server.running():`` serves for the block."""
        self.start()
        try:
            yield self
        finally:
            self.stop()


def allowed_hosts_for(host: str) -> list[str]:
    """Host names the ``Host`` header may carry: loopback names, plus ``host`` when it is a specific address."""
    hosts = list(LOOPBACK_HOSTS)
    if host not in ("0.0.0.0", "::", "") and host not in hosts:
        hosts.append(host)
    return hosts


def serve(
    study_dir: str | Path,
    *,
    host: str = "127.0.0.1",
    port: int = 8765,
    token: str | None = None,
    extra_hosts: Sequence[str] = (),
) -> None:
    """Serves a study until interrupted (``antmaze-hirl study serve``), printing the participants' URL."""
    import uvicorn

    study = Study(study_dir)
    token = token or new_token()
    if host not in LOOPBACK_HOSTS:
        print(
            f"warning: serving on {host}, not loopback: anyone who can reach this machine and knows the token "
            "can use the study",
            file=sys.stderr,
        )
    sock = bind_socket(host, port)
    port = int(sock.getsockname()[1])  # the one picked, when port 0 asked for any
    app = create_app(study, token=token, allowed_hosts=[*allowed_hosts_for(host), *extra_hosts])
    print(f"study {study.folder} ({len(study.participant_ids)} participants): open {study_url(host, port, token)}")
    try:
        uvicorn.Server(uvicorn.Config(app, log_level="warning", lifespan="off")).run(sockets=[sock])
    finally:
        sock.close()
        study.close()
