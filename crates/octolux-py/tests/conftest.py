"""What the tests share: the `octolux` binary that the CLI-side checks run.

The Python module and `octolux.dask` need no binary (they run octolux's code in-process); only
the tests that compare them with the command line do. The binary is, in this order:
`$OCTOLUX_BIN` (tests/pytest.rs sets it to the one cargo just built), this checkout's
`target/release/octolux`, then `octolux` on the PATH (`cargo install --path crates/octolux-cli`).
The checkout's build comes before the PATH so that an older installed binary is not compared
with the module built from this checkout.
"""
import os
import shutil
from pathlib import Path
from typing import Mapping, Optional

ROOT = Path(__file__).resolve().parents[3]

HOW_TO_GET_ONE = (
    "no octolux binary: set OCTOLUX_BIN to one, or build it (cargo build --release -p octolux-cli: "
    "target/release/octolux), or install it on the PATH (cargo install --path crates/octolux-cli)"
)


def find_octolux_bin(environ: Mapping[str, str] = os.environ, root: Path = ROOT) -> Optional[str]:
    """The binary by the rule above, or None. A set `OCTOLUX_BIN` that is not a file is an
    error, not a reason to look elsewhere: it names what the user asked for."""
    named = environ.get("OCTOLUX_BIN")
    if named:
        if not Path(named).is_file():
            raise FileNotFoundError(f"OCTOLUX_BIN={named} is not a file; unset it, or name the octolux binary")
        return named
    built = root / "target" / "release" / "octolux"
    if built.is_file() and os.access(built, os.X_OK):
        return str(built)
    return shutil.which("octolux", path=environ.get("PATH"))
