"""A Jupyter kernel of this very interpreter, for the tests that run notebooks."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path
from typing import Any

FALLBACK_KERNEL = "stepramp-python3"


def runs_this_interpreter(argv: list[str]) -> bool:
    if not argv:
        return False
    major, minor = sys.version_info[:2]
    # jupyter_client launches these names as sys.executable (format_kernel_cmd).
    if argv[0] in ("python", f"python{major}", f"python{major}.{minor}"):
        return True
    found = shutil.which(argv[0])
    return found is not None and Path(found).resolve() == Path(sys.executable).resolve()


def kernel_for_this_interpreter(fallback_dir: Path, *, manager: Any = None) -> tuple[str, Any]:
    """(kernel name, KernelSpecManager) that launch a kernel of sys.executable: `python3`
    if `manager` (default: the standard search path) has a spec that does, otherwise a
    spec registered into `fallback_dir` (nothing is installed anywhere else)."""
    from jupyter_client.kernelspec import KernelSpecManager, NoSuchKernel

    ksm = manager if manager is not None else KernelSpecManager()
    try:
        if runs_this_interpreter(ksm.get_kernel_spec("python3").argv):
            return "python3", ksm
    except NoSuchKernel:
        pass
    from ipykernel.kernelspec import install

    install(prefix=str(fallback_dir), kernel_name=FALLBACK_KERNEL,
            display_name=f"stepramp ({sys.executable})")
    kernels = fallback_dir / "share" / "jupyter" / "kernels"
    return FALLBACK_KERNEL, KernelSpecManager(kernel_dirs=[str(kernels)])
