import subprocess
import sys


def test_import_graybox_loads_neither_mlflow_nor_prefect():
    code = ("import sys, graybox, graybox.simulator, graybox.telemetry; "
            "bad = [m for m in ('mlflow', 'prefect') if m in sys.modules]; "
            "print(bad); sys.exit(1 if bad else 0)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr


def test_graybox_source_never_imports_mlflow_or_prefect():
    import pathlib

    import graybox
    root = pathlib.Path(graybox.__file__).parent
    offenders = [str(path) for path in root.rglob("*.py")
                 if any(line.lstrip().startswith(("import mlflow", "from mlflow", "import prefect",
                                                  "from prefect"))
                        for line in path.read_text().splitlines())]
    assert offenders == []
