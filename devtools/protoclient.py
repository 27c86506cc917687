"""An explorer session at the Bokeh protocol level: the messages chromium sends
(the GET, PULL-DOC, the size patches, `document_ready`, a `tap` per click),
without drawing, so that a load test measures the server, not browsers on
its cores.  A click costs the client milliseconds.
"""

import asyncio
import json
import re
import uuid

from tornado.httpclient import AsyncHTTPClient, HTTPRequest
from tornado.websocket import websocket_connect

# a finished run's summary "<model>: A* = .., m* = .., mu = .." (not "Running ... at A* = ")
_DONE = re.compile(r": A\* = [^,]*, m\* = [^,]*, mu = ")
_FAILED = re.compile(r"run failed|server's limit|Drawing the run failed")
_MAP_DONE = re.compile(r"Map finished: |Map from this server's cache ")
_MAP_FAILED = re.compile(r"The map failed|Not computed|Drawing the map failed|Map cancelled")


def _walk(obj, out):
    """Every serialized Bokeh model in a JSON tree, by id."""
    if isinstance(obj, dict):
        if obj.get("type") == "object" and "id" in obj and "name" in obj:
            out.setdefault(obj["id"], obj)
        for v in obj.values():
            _walk(v, out)
    elif isinstance(obj, list):
        for v in obj:
            _walk(v, out)
    return out


class ProtocolSession:
    """One explorer session over Bokeh's websocket protocol (`query`: a
    link's "?..." part); `bytes`: the bytes received per message type."""

    def __init__(self, url, timeout=180.0, cookies=None, query=""):
        self.url = url.rstrip("/") + "/"
        self.query = query
        self.timeout = timeout
        # what the server or a proxy sets comes back (a sticky proxy routes by it)
        self.cookies = dict(cookies or {})
        self.models = {}
        self.bytes = {}
        self._waiters = []
        self._reader = None
        self.conn = None

    async def open(self):
        """Load the page and report it ready."""
        await self._connect(await self._get())
        self._listen()
        self.announce()

    async def _get(self):
        """The page (a client of its own: Tornado's shared one queues beyond 10 requests)."""
        http = AsyncHTTPClient(force_instance=True)
        try:
            page = await http.fetch(
                self.url + self.query, request_timeout=self.timeout, headers=self._cookie_header()
            )
        finally:
            http.close()
        for line in page.headers.get_list("Set-Cookie"):
            name, _, value = line.split(";", 1)[0].partition("=")
            self.cookies[name.strip()] = value.strip()
        self.bytes["html"] = len(page.body)
        return page

    async def _connect(self, page):
        """The websocket, and the document pulled."""
        token = re.search(r'"token":"([^"]+)"', page.body.decode()).group(1)
        ws = HTTPRequest(
            "ws" + self.url[4:] + "ws",
            headers={"Origin": self.url.rstrip("/"), **self._cookie_header()},
            request_timeout=self.timeout,
        )
        self.conn = await websocket_connect(ws, subprotocols=["bokeh", token], max_message_size=1 << 30)
        header, _ = await self._read()
        if header["msgtype"] != "ACK":
            raise RuntimeError(f"expected ACK, got {header['msgtype']}")
        self._send("PULL-DOC-REQ", {})
        while True:  # patches sent before the reply are in the document it carries
            header, content = await self._read()
            if header["msgtype"] == "PULL-DOC-REPLY":
                break
            if header["msgtype"] != "PATCH-DOC":
                raise RuntimeError(f"expected PULL-DOC-REPLY, got {header['msgtype']}")
        _walk(json.loads(content), self.models)

    def _listen(self):
        self._reader = asyncio.ensure_future(self._loop())
        # the map: the figure whose clicks the server listens to
        self.map = next(
            f
            for f in self._figures()
            if "tap" in (f["attributes"].get("subscribed_events") or {}).get("entries", [])
        )

    def announce(self):
        """As the page: its size, then document_ready."""
        self._sizes([self.map], 0)
        self._event("document_ready", [])

    async def click(self, fx, fy):
        """Tap the map at fractions (fx, fy) of its ranges: ("done" | "error", summary)."""
        (x0, x1), (y0, y1) = self._range("x_range"), self._range("y_range")
        done = self._wait(lambda s: bool(_DONE.search(s) or _FAILED.search(s)))
        keys = {"type": "map", "entries": [["shift", False], ["ctrl", False], ["alt", False]]}
        at = [["sx", 100 + 700 * fx], ["sy", 400 - 380 * fy]]
        at += [["x", x0 + fx * (x1 - x0)], ["y", y0 + fy * (y1 - y0)]]
        self._event("tap", [["model", {"id": self.map["id"]}], *at, ["modifiers", keys]])
        text = await asyncio.wait_for(done, self.timeout)
        if _FAILED.search(text):
            return "error", text
        # as the page after drawing new data: its axes' widths change
        self._sizes([f for f in self._figures() if f is not self.map], 1)
        return "done", text

    def map_ended(self):
        """A future: ("done" | "error", text) once the linked map is finished or failed."""

        async def ended(found):
            text = await found
            return ("error" if _MAP_FAILED.search(text) else "done"), text

        found = self._wait(lambda s: bool(_MAP_DONE.search(s) or _MAP_FAILED.search(s)))
        return asyncio.ensure_future(ended(found))

    def close(self):
        if self.conn is not None:
            self.conn.close()
        if self._reader is not None:
            self._reader.cancel()

    def _cookie_header(self):
        return {"Cookie": "; ".join(f"{k}={v}" for k, v in self.cookies.items())} if self.cookies else {}

    def _send(self, msgtype, content):
        self.conn.write_message(json.dumps({"msgid": uuid.uuid4().hex, "msgtype": msgtype}))
        self.conn.write_message("{}")
        self.conn.write_message(json.dumps(content))

    async def _read(self):
        """One message: (header, content text); buffers are skipped."""
        h = await self.conn.read_message()
        if h is None:
            raise ConnectionError("the server closed the websocket")
        header = json.loads(h)
        size = len(h) + len(await self.conn.read_message())  # metadata
        content = await self.conn.read_message()
        size += len(content)
        for _ in range(2 * header.get("num_buffers", 0)):
            size += len(await self.conn.read_message())
        self.bytes[header["msgtype"]] = self.bytes.get(header["msgtype"], 0) + size
        return header, content

    async def _loop(self):
        try:
            while True:
                header, content = await self._read()
                if header["msgtype"] != "PATCH-DOC":
                    continue
                if '"Figure"' in content:
                    _walk(json.loads(content), self.models)
                for w in list(self._waiters):
                    if w[0](content) and not w[1].done():
                        w[1].set_result(content)
                        self._waiters.remove(w)
        except Exception as exc:  # noqa: BLE001 - passed to the waiters
            for _, f in self._waiters:
                if not f.done():
                    f.set_exception(exc if isinstance(exc, ConnectionError) else ConnectionError(repr(exc)))

    def _wait(self, predicate):
        f = asyncio.get_running_loop().create_future()
        self._waiters.append((predicate, f))
        return f

    def _patch(self, events):
        self._send("PATCH-DOC", {"events": events})

    def _event(self, name, entries):
        data = {"type": "event", "name": name, "values": {"type": "map", "entries": entries}}
        self._patch([{"kind": "MessageSent", "msg_type": "bokeh_event", "msg_data": data}])

    def _figures(self):
        return [m for m in self.models.values() if m["name"] == "Figure"]

    def _sizes(self, figures, shrink):
        """A page's size reports: one patch per figure, as BokehJS sends."""
        for f in figures:
            a = f["attributes"]
            w, h = a.get("width") or 900, a.get("height") or 300
            sizes = dict(inner_width=w - 175 - shrink, inner_height=h - 70, outer_width=w, outer_height=h)
            self._patch(
                [
                    {"kind": "ModelChanged", "model": {"id": f["id"]}, "attr": attr, "new": v}
                    for attr, v in sizes.items()
                ]
            )

    def _range(self, which):
        ref = self.map["attributes"][which]["id"]
        a = self.models[ref]["attributes"]
        return a["start"], a["end"]
