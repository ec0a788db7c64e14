"""The command's temporary Prefect server: started by the command itself where no server can
be set, so that Prefect never imports its server's modules in the command's process."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import urllib.error
import urllib.request

import pytest

from flows.commands.temporary_server import no_server_set


@pytest.fixture
def home_and_directory(tmp_path):
    (tmp_path / "home").mkdir()
    (tmp_path / "work").mkdir()
    return {"PREFECT_HOME": str(tmp_path / "home")}, tmp_path / "work"


def test_no_server_is_set_only_where_nothing_could_set_one(home_and_directory):
    environ, directory = home_and_directory
    assert no_server_set(environ, directory)
    for name in ("PREFECT_API_URL", "PREFECT_PROFILE", "PREFECT_PROFILES_PATH",
                 "PREFECT_SERVER_ALLOW_EPHEMERAL_MODE"):
        assert not no_server_set({**environ, name: "x"}, directory), name
    assert no_server_set({**environ, "PREFECT_API_URL": ""}, directory)


@pytest.mark.parametrize("name, text, certain", [
    ("home/profiles.toml", '[profiles.local]\nPREFECT_API_URL = "http://h:4200/api"\n', False),
    ("home/profiles.toml", '[profiles.local]\nPREFECT_LOGGING_LEVEL = "INFO"\n', True),
    ("home/profiles.toml", 'active = "ephemeral"\n', True),
    # Prefect's own "local" profile names a server; the user's file only makes it active
    ("home/profiles.toml", 'active = "local"\n', False),
    ("home/profiles.toml", 'active = "ephemeral\n', False),           # not TOML

    ("work/prefect.toml", '[logging]\nlevel = "INFO"\n', False),
    ("work/pyproject.toml", '[tool.prefect.api]\nurl = "http://h:4200/api"\n', False),
    ("work/pyproject.toml", '[project]\nname = "x"\n', True),
    ("work/.env", "PREFECT_API_URL=http://h:4200/api\n", False),
    ("work/.env", "OTHER=1\n", True),
])
def test_a_settings_file_that_may_set_a_server_leaves_the_decision_to_prefect(
        home_and_directory, name, text, certain):
    environ, directory = home_and_directory
    (directory.parent / name).write_text(text)
    assert no_server_set(environ, directory) is certain


CHECK = """
import json, os, sys
from flows.commands.temporary_server import TemporaryServer
server = TemporaryServer().start(announce=False)
before = "prefect" in sys.modules
server.wait()
from prefect.client.orchestration import get_client
from prefect.settings import PREFECT_API_URL
with get_client(sync_client=True) as client:
    error = client.api_healthcheck()
print(json.dumps({"prefect_before_wait": before, "healthy": error is None,
                  "url": os.environ["PREFECT_API_URL"], "prefect_url": PREFECT_API_URL.value(),
                  "server_modules": "prefect.server.api.server" in sys.modules}))
"""


def test_the_command_starts_the_server_child_and_prefect_talks_to_it(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "PREFECT_API_URL"}
    env.update(PREFECT_HOME=str(tmp_path / ".prefect"),
               PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS="180")
    done = subprocess.run([sys.executable, "-c", CHECK], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    seen = json.loads(done.stdout.strip().splitlines()[-1])
    assert seen["healthy"] and not seen["prefect_before_wait"]
    assert seen["url"].startswith("http://127.0.0.1:") and seen["url"].endswith("/api")
    assert seen["prefect_url"] == seen["url"]
    assert not seen["server_modules"]
    # the child stopped with the command
    opener = urllib.request.build_opener(urllib.request.ProxyHandler({}))
    with pytest.raises(urllib.error.URLError):
        opener.open(seen["url"] + "/health", timeout=5)
