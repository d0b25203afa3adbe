"""What the tests share: how to run the command line they compare the package with."""

import os
import pathlib

REPO = pathlib.Path(__file__).resolve().parents[2]


def cli_command(*args: str) -> list[str]:
    """The command line `clearance ARGS…`: the binary `CLEARANCE_CLI` names (CI sets it
    to the release binary it has built), else the workspace's CLI through `cargo run`
    (built first if it is not current)."""
    binary = os.environ.get("CLEARANCE_CLI")
    if binary:
        return [str(pathlib.Path(binary).resolve()), *args]
    return ["cargo", "run", "-q", "--manifest-path", str(REPO / "Cargo.toml"), "-p", "clearance-cli", "--", *args]
