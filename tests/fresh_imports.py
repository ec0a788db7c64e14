"""What a fresh interpreter loads: the import-cost tests of tests/flows and tests/graybox."""
from __future__ import annotations

import subprocess
import sys


def loaded_after(imports: str, prefixes: tuple[str, ...]) -> str:
    """The modules named with one of ``prefixes`` that a new Python process has loaded after
    ``import sys, <imports>``: their sorted list as it prints it (``"[]"``: none)."""
    code = (f"import sys, {imports}; "
            f"print(sorted(m for m in sys.modules if m.startswith({prefixes!r})))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True)
    return done.stdout.strip()
