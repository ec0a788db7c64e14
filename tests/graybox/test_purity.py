import ast
import pathlib
import subprocess
import sys
import tomllib

import graybox

ROOT = pathlib.Path(graybox.__file__).resolve().parents[1]
#: what the pipeline extra installs: graybox must import and fit without any of them
PIPELINE_MODULES = ("mlflow", "prefect", "fastapi", "matplotlib", "rich")
#: graybox modules that import an optional extra of their own (progpy, fmu)
OPTIONAL_MODULES = ("graybox.models.progpy", "graybox.models.fmu")


def test_import_graybox_loads_neither_mlflow_nor_prefect():
    code = ("import sys, graybox, graybox.simulation, graybox.telemetry; "
            "bad = [m for m in ('mlflow', 'prefect') if m in sys.modules]; "
            "print(bad); sys.exit(1 if bad else 0)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr


def test_every_graybox_module_imports_and_the_tiers_fit_without_the_pipeline_packages():
    # the pipeline packages made unimportable, as in an environment of `pip install .` alone
    code = f"""
import importlib, pkgutil, sys
import numpy as np

class Absent:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in {PIPELINE_MODULES!r}:
            raise ImportError(f"{{name}} is not installed")

sys.meta_path.insert(0, Absent())
import graybox as gb
for module in pkgutil.walk_packages(gb.__path__, "graybox."):
    if module.name not in {OPTIONAL_MODULES!r}:
        importlib.import_module(module.name)
z = np.random.default_rng(0).normal(size=600)
linear = gb.fit_ar(z, max_order=4)
[fit] = gb.fit_networks([gb.lagged(linear.innovations(z), 2, 1)], hidden=2)
gb.describe_noise(linear.innovations(z))
loaded = sorted(m for m in sys.modules if m.split(".")[0] in {PIPELINE_MODULES!r})
print(loaded)
sys.exit(1 if loaded else 0)
"""
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            cwd=ROOT)
    assert result.returncode == 0, result.stdout + result.stderr


def test_graybox_source_never_imports_mlflow_or_prefect():
    root = pathlib.Path(graybox.__file__).parent
    offenders = [str(path) for path in root.rglob("*.py")
                 if any(line.lstrip().startswith(("import mlflow", "from mlflow", "import prefect",
                                                  "from prefect"))
                        for line in path.read_text().splitlines())]
    assert offenders == []


def third_party_imports(package: pathlib.Path) -> set[str]:
    """Top-level names of the modules a package's source imports, stdlib and itself aside."""
    names = set()
    for path in package.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names |= {alias.name.split(".")[0] for alias in node.names}
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names.add(node.module.split(".")[0])
    return names - set(sys.stdlib_module_names) - {package.name}


def requirement_name(requirement: str) -> str:
    return requirement.split(";")[0].split("[")[0].split("<")[0].split(">")[0].split("=")[0] \
        .strip().lower()


def test_pip_install_alone_brings_what_graybox_imports_and_no_pipeline_package():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    core = {requirement_name(r) for r in project["dependencies"]}
    extras = project["optional-dependencies"]
    optional = {requirement_name(r) for name in ("progpy", "fmu") for r in extras[name]}
    needed = third_party_imports(ROOT / "graybox")
    assert needed - core - optional == set()
    assert core.isdisjoint(PIPELINE_MODULES)
    assert set(PIPELINE_MODULES) <= {requirement_name(r) for r in extras["pipeline"]}


def test_make_install_asks_for_the_pipeline_extra():
    makefile = (ROOT / "Makefile").read_text()
    install = [line for line in makefile.splitlines() if "pip install" in line and "-e" in line]
    assert install and all("pipeline" in line for line in install)
