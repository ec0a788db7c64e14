"""The registry benchmark's nightly path on a tiny configuration: a short history, one
untimed night, one timed night; only the timed night is counted (no times are checked)."""
from benchmarks.registry_bench import main


def test_nightly_path_with_history_and_an_untimed_night(tmp_path, capsys):
    assert main(["--nightly", "--assets", "2", "--nights", "1", "--warmup", "1",
                 "--history", "2", "--workdir", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "filled 2 runs and versions per asset" in out
    assert ("2 assets x 1 nights = 2 asset-nights, record_fit and commit_watermark per asset, "
            "2 nights of history, 1 untimed night(s) first") in out
    for call in ("watermark", "baseline", "record", "commit_watermark", "total"):
        assert f"| {call:<16} |" in out


def test_nightly_path_through_the_client_calls(tmp_path, capsys):
    assert main(["--nightly", "--assets", "1", "--nights", "1", "--client-path",
                 "--workdir", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "embedded SQLite store (WAL), client path: 1 assets x 1 nights" in out


def test_nightly_path_as_the_flow_commits_a_group(tmp_path, capsys):
    for mode in (["--group", "2"], ["--group", "2", "--one-by-one"]):
        assert main(["--nightly", "--assets", "2", "--nights", "1", *mode,
                     "--workdir", str(tmp_path / mode[-1])]) == 0
    out = capsys.readouterr().out
    assert "2 asset-nights, record_group + commit_watermarks of 2 assets" in out
    assert "2 asset-nights, groups of 2 assets, each recorded and committed alone" in out
