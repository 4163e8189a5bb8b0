"""A tiny local stand-in for the Hugging Face Hub's HTTP API, for running the real huggingface_hub client offline.

It answers the endpoints a dataset push uses (create repo, validate the card's YAML, preupload, commit, branch,
tag) the way the Hub does on success, tells the client to send every file as a regular (inline, base64) git
blob, and records what arrives: the created repos, the committed files with their bytes, branches and tags.
The large-file path (LFS/Xet) is not emulated: the Hub decides it per file, and here it is never chosen.
"""

from __future__ import annotations

import base64
import json
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any


@dataclass
class Received:
    repos: list[dict[str, Any]] = field(default_factory=list)  # create-repo payloads
    commits: list[dict[str, Any]] = field(default_factory=list)  # {"repo", "revision", "header", "files"}
    branches: list[str] = field(default_factory=list)
    tags: list[tuple[str, str]] = field(default_factory=list)  # (tag, revision)
    tokens: set[str] = field(default_factory=set)  # the Authorization headers seen


class _Handler(BaseHTTPRequestHandler):
    received: Received
    refuse: dict[str, int]  # endpoint ("create", "validate-yaml", "commit", ...) -> the error status it answers

    def log_message(self, format: str, *args: Any) -> None:  # quiet
        pass

    def _reply(self, body: Any, status: int = 200) -> None:
        data = json.dumps(body).encode()
        self.send_response(status)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(data)))
        self.end_headers()
        self.wfile.write(data)

    def _body(self) -> bytes:
        return self.rfile.read(int(self.headers.get("Content-Length", 0)))

    def do_DELETE(self) -> None:  # delete_tag: no such tag yet
        self._body()
        self.send_response(404)
        self.send_header("X-Error-Code", "RevisionNotFound")
        self.send_header("Content-Length", "0")
        self.end_headers()

    def do_POST(self) -> None:
        self.received.tokens.add(self.headers.get("Authorization", ""))
        body = self._body()
        parts = self.path.split("?")[0].strip("/").split("/")
        endpoint = parts[1] if len(parts) < 6 else parts[4]  # repos/create -> "repos"; datasets/o/n/commit -> "commit"
        if endpoint in self.refuse:
            error = {"error": "refused here", "errors": [{"message": "refused here"}]}
            return self._reply(error, self.refuse[endpoint])
        host = f"http://{self.headers['Host']}"
        if parts == ["api", "repos", "create"]:
            payload = json.loads(body)
            self.received.repos.append(payload)
            return self._reply({"url": f"{host}/datasets/{payload['organization']}/{payload['name']}"})
        if parts == ["api", "validate-yaml"]:
            return self._reply({})
        if len(parts) == 6 and parts[:2] == ["api", "datasets"]:
            repo, kind, rev = f"{parts[2]}/{parts[3]}", parts[4], parts[5]
            if kind == "preupload":
                files = json.loads(body)["files"]
                modes = [{"path": f["path"], "uploadMode": "regular", "shouldIgnore": False} for f in files]
                return self._reply({"files": modes})
            if kind == "commit":
                lines = [json.loads(line) for line in body.splitlines() if line.strip()]
                files = {
                    item["value"]["path"]: base64.b64decode(item["value"]["content"])
                    for item in lines
                    if item["key"] == "file"
                }
                header = next(item["value"] for item in lines if item["key"] == "header")
                self.received.commits.append({"repo": repo, "revision": rev, "header": header, "files": files})
                return self._reply({"commitUrl": f"{host}/datasets/{repo}/commit/{'0' * 40}", "commitOid": "0" * 40})
            if kind == "branch":
                self.received.branches.append(rev)
                return self._reply({})
            if kind == "tag":
                self.received.tags.append((json.loads(body)["tag"], rev))
                return self._reply({})
        self._reply({"error": f"not emulated: POST {self.path}"}, 404)


@contextmanager
def local_hub(refuse: dict[str, int] | None = None) -> Iterator[tuple[str, Received]]:
    """Serve on 127.0.0.1 (a free port) while inside; yields the endpoint URL (for ``HF_ENDPOINT``) and what
    arrived. `refuse` makes endpoints answer with an error status (``{"repos": 401}``: creating the repo;
    ``"validate-yaml"``, ``"preupload"``, ``"commit"``, ``"tag"``, ``"branch"``), as the Hub does when it refuses."""
    received = Received()
    handler = type("Handler", (_Handler,), {"received": received, "refuse": refuse or {}})
    server = ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}", received
    finally:
        server.shutdown()
        server.server_close()
