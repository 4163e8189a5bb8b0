"""A tiny local stand-in for the Hugging Face Hub's HTTP API, for running the real huggingface_hub client offline.

Both ways, the way the Hub answers on success:

- a push: create repo, validate the card's YAML, preupload, commit, branch, tag. Every file is sent as a regular
  (inline, base64) git blob; preupload tells the client each file's current oid (git SHA-1), as the Hub does, so
  the client drops a file already there unchanged (how an interrupted push resumes). What arrives is recorded:
  the created repos, each commit's files with their bytes, branches and tags, and the files each branch holds.
- a download (`snapshot_download`): repo info at a revision (`/api/datasets/{id}/revision/{rev}`, the commit in
  `sha`), the refs, the recursive tree, and `HEAD`/`GET /datasets/{id}/resolve/{rev}/{path}` with the
  `X-Repo-Commit` and `ETag` headers and HTTP `Range` (206) for a download resumed mid-file.

The large-file paths (LFS/Xet) are not emulated: the Hub decides them per file, here they are never chosen, and
`tree` lists no `lfs`/`xetHash` for a file, so the client downloads it over plain HTTP.
Faults, as a test asks for them: `refuse` (an endpoint answers an error status), `commits_allowed` (commits
beyond that many are refused: an interrupted push), `cut` (the first GET of a file stops after that many bytes
and closes the connection), `hang` (a GET of a file sends that many bytes, then waits until the server stops:
a download a test kills).
"""

from __future__ import annotations

import base64
import hashlib
import json
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any
from urllib.parse import unquote

Files = dict[str, bytes]


def git_oid(data: bytes) -> str:
    """A file's git blob id, what the Hub reports as its oid (and the client computes for a regular file)."""
    return hashlib.sha1(b"blob %d\0" % len(data) + data).hexdigest()  # git's own hash


def commit_id(files: Files, name: str) -> str:
    """A stable 40-hex commit id for a served revision."""
    digest = hashlib.sha1(name.encode())
    for path in sorted(files):
        digest.update(path.encode() + git_oid(files[path]).encode())
    return digest.hexdigest()


@dataclass
class Received:
    repos: list[dict[str, Any]] = field(default_factory=list)  # create-repo payloads
    commits: list[dict[str, Any]] = field(default_factory=list)  # {"repo", "revision", "header", "files"}
    branches: list[str] = field(default_factory=list)
    tags: list[tuple[str, str]] = field(default_factory=list)  # (tag, revision)
    tokens: set[str] = field(default_factory=set)  # the Authorization headers seen
    held: dict[tuple[str, str], Files] = field(default_factory=dict)  # (repo, branch) -> its files after the commits
    gets: list[tuple[str, str]] = field(default_factory=list)  # (path, Range header or "") of each file GET
    # what the stand-in serves for download: repo -> ref name (branch or tag) -> files; tags are refs named v*
    served: dict[str, dict[str, Files]] = field(default_factory=dict)
    commits_allowed: int | None = None  # refuse commits beyond this many (an interrupted push); None: no limit
    cut: dict[str, int] = field(default_factory=dict)  # path -> bytes sent by its first GET before the cut
    hang: dict[str, int] = field(default_factory=dict)  # path -> bytes sent before the GET waits for shutdown
    stopping: threading.Event = field(default_factory=threading.Event)


class _Handler(BaseHTTPRequestHandler):
    received: Received
    refuse: dict[str, int]  # endpoint ("create", "validate-yaml", "commit", "revision", ...) -> error status
    protocol_version = "HTTP/1.1"

    def log_message(self, format: str, *args: Any) -> None:  # quiet
        pass

    def _reply(self, body: Any, status: int = 200, headers: dict[str, str] | None = None) -> None:
        data = json.dumps(body).encode()
        self.send_response(status)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(data)))
        for key, value in (headers or {}).items():
            self.send_header(key, value)
        self.end_headers()
        self.wfile.write(data)

    def _error(self, status: int, code: str | None = None) -> None:
        error = {"error": "refused here", "errors": [{"message": "refused here"}]}
        default = {401: "RepoNotFound", 403: "GatedRepo", 404: "RepoNotFound"}.get(status)
        code = default if code is None else code
        self._reply(error, status, {"X-Error-Code": code} if code else None)

    def _body(self) -> bytes:
        return self.rfile.read(int(self.headers.get("Content-Length", 0)))

    def do_DELETE(self) -> None:  # delete_tag: no such tag yet
        self._body()
        self._reply({}, 404, {"X-Error-Code": "RevisionNotFound"})

    # -- download -------------------------------------------------------------------------------------------------

    def _files_at(self, repo: str, rev: str) -> tuple[str, Files] | None:
        """(commit, files) of `repo` at a ref name or a commit id."""
        for name, files in self.received.served.get(repo, {}).items():
            commit = commit_id(files, name)
            if rev in (name, commit):
                return commit, files
        return None

    def do_HEAD(self) -> None:
        self._resolve(head=True)

    def do_GET(self) -> None:
        path = unquote(self.path.split("?")[0])
        parts = path.strip("/").split("/")
        if len(parts) > 5 and parts[0] == "datasets" and parts[3] == "resolve":
            return self._resolve(head=False)
        if len(parts) < 5 or parts[:2] != ["api", "datasets"]:  # e.g. the client's own /api/agent-harnesses
            return self._reply({"error": f"not emulated: GET {self.path}"}, 404)
        self.received.tokens.add(self.headers.get("Authorization", ""))
        repo, kind = f"{parts[2]}/{parts[3]}", parts[4]
        if kind in self.refuse:
            return self._error(self.refuse[kind])
        pushed = self.received.held.get((repo, unquote(parts[5]) if len(parts) > 5 else "main"))
        if kind == "revision" and pushed is not None:  # after a commit with nothing new: the branch's head
            return self._reply({"id": repo, "sha": commit_id(pushed, "pushed"), "private": False, "siblings": []})
        if repo not in self.received.served:
            return self._error(404)
        if kind == "refs":
            return self._reply(self._refs(repo))
        found = self._files_at(repo, parts[5] if len(parts) > 5 else "main")
        if found is None:
            return self._error(404, "RevisionNotFound")
        commit, files = found
        if kind == "revision":
            siblings = [{"rfilename": p} for p in sorted(files)]
            return self._reply({"id": repo, "sha": commit, "private": False, "siblings": siblings, "tags": []})
        if kind == "tree":
            entries = [{"type": "file", "oid": git_oid(d), "size": len(d), "path": p} for p, d in sorted(files.items())]
            return self._reply(entries)
        return self._reply({"error": f"not emulated: GET {self.path}"}, 404)

    def _refs(self, repo: str) -> dict[str, Any]:
        def ref(name: str, kind: str) -> dict[str, str]:
            files = self.received.served[repo][name]
            return {"name": name, "ref": f"refs/{kind}/{name}", "targetCommit": commit_id(files, name)}

        names = sorted(self.received.served[repo])
        return {
            "branches": [ref(n, "heads") for n in names if not n.startswith("v")],
            "tags": [ref(n, "tags") for n in names if n.startswith("v")],
            "converts": [],
        }

    def _resolve(self, *, head: bool) -> None:
        """`/datasets/{owner}/{name}/resolve/{rev}/{path}`: a file's bytes (from `Range`'s start when asked)."""
        parts = unquote(self.path.split("?")[0]).strip("/").split("/")
        repo, rev, rel = f"{parts[1]}/{parts[2]}", parts[4], "/".join(parts[5:])
        if "resolve" in self.refuse:
            return self._error(self.refuse["resolve"])
        found = self._files_at(repo, rev)
        if found is None or rel not in found[1]:
            return self._error(404, "EntryNotFound" if found else "RepoNotFound")
        commit, data = found[0], found[1][rel]
        start = int(self.headers.get("Range", "bytes=0-").split("=")[1].split("-")[0])
        if not head:
            self.received.gets.append((rel, self.headers.get("Range", "")))
        self.send_response(206 if start else 200)
        self.send_header("X-Repo-Commit", commit)
        self.send_header("ETag", f'"{git_oid(data)}"')
        self.send_header("Content-Length", str(len(data) - start))
        if start:
            self.send_header("Content-Range", f"bytes {start}-{len(data) - 1}/{len(data)}")
        self.end_headers()
        if head:
            return
        if rel in self.received.hang:
            self.wfile.write(data[start : start + self.received.hang[rel]])
            self.wfile.flush()
            self.received.stopping.wait()
            self.close_connection = True
            return
        cut = self.received.cut.pop(rel, None)
        self.wfile.write(data[start : start + cut] if cut is not None else data[start:])
        if cut is not None:
            self.wfile.flush()
            self.close_connection = True

    # -- push -----------------------------------------------------------------------------------------------------

    def do_POST(self) -> None:
        self.received.tokens.add(self.headers.get("Authorization", ""))
        body = self._body()
        parts = self.path.split("?")[0].strip("/").split("/")
        endpoint = parts[1] if len(parts) < 6 else parts[4]  # repos/create -> "repos"; datasets/o/n/commit -> "commit"
        if endpoint in self.refuse:
            return self._error(self.refuse[endpoint], "")
        host = f"http://{self.headers['Host']}"
        if parts == ["api", "repos", "create"]:
            payload = json.loads(body)
            self.received.repos.append(payload)
            return self._reply({"url": f"{host}/datasets/{payload['organization']}/{payload['name']}"})
        if parts == ["api", "validate-yaml"]:
            return self._reply({})
        if len(parts) == 6 and parts[:2] == ["api", "datasets"]:
            return self._repo_post(f"{parts[2]}/{parts[3]}", parts[4], unquote(parts[5]), body, host)
        self._reply({"error": f"not emulated: POST {self.path}"}, 404)

    def _repo_post(self, repo: str, kind: str, rev: str, body: bytes, host: str) -> None:
        held = self.received.held.setdefault((repo, rev), {})
        if kind == "preupload":
            files = json.loads(body)["files"]
            modes = [
                {"path": f["path"], "uploadMode": "regular", "shouldIgnore": False, "oid": _oid(held, f["path"])}
                for f in files
            ]
            return self._reply({"files": modes})
        if kind == "commit":
            limit = self.received.commits_allowed
            if limit is not None and len(self.received.commits) >= limit:
                return self._error(400, "")
            lines = [json.loads(line) for line in body.splitlines() if line.strip()]
            files = {
                item["value"]["path"]: base64.b64decode(item["value"]["content"])
                for item in lines
                if item["key"] == "file"
            }
            header = next(item["value"] for item in lines if item["key"] == "header")
            self.received.commits.append({"repo": repo, "revision": rev, "header": header, "files": files})
            held.update(files)
            return self._reply({"commitUrl": f"{host}/datasets/{repo}/commit/{'0' * 40}", "commitOid": "0" * 40})
        if kind == "branch":
            self.received.branches.append(rev)
            held.update(self.received.held.get((repo, "main"), {}))
            return self._reply({})
        if kind == "tag":
            self.received.tags.append((json.loads(body)["tag"], rev))
            return self._reply({})
        self._reply({"error": f"not emulated: POST {self.path}"}, 404)


def _oid(held: Files, path: str) -> str | None:
    return git_oid(held[path]) if path in held else None


@contextmanager
def local_hub(refuse: dict[str, int] | None = None, received: Received | None = None) -> Iterator[tuple[str, Received]]:
    """Serve on 127.0.0.1 (a free port) while inside; yields the endpoint URL (for ``HF_ENDPOINT``) and what
    arrived. `refuse` makes endpoints answer with an error status (``{"repos": 401}``: creating the repo;
    ``"validate-yaml"``, ``"preupload"``, ``"commit"``, ``"tag"``, ``"branch"``; for downloads ``"revision"``,
    ``"refs"``, ``"tree"``, ``"resolve"``), as the Hub does when it refuses. `received` may come prepared: the
    datasets it `served`, the faults (`commits_allowed`, `cut`, `hang`), or what an earlier stand-in kept (`held`,
    to resume a push)."""
    received = received if received is not None else Received()
    handler = type("Handler", (_Handler,), {"received": received, "refuse": refuse or {}})
    server = ThreadingHTTPServer(("127.0.0.1", 0), handler)
    server.daemon_threads = True
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}", received
    finally:
        received.stopping.set()
        server.shutdown()
        server.server_close()
