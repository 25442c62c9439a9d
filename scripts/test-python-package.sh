#!/usr/bin/env bash
# The Python package installed as a lab would (docs/python.md): a virtual environment with the
# system's site packages (numpy), `pip install --no-build-isolation ./python` offline, then imported
# from outside the checkout. $1: a configured build folder whose module the install reuses.
set -euo pipefail
source_dir=$(cd "$(dirname "$0")/.." && pwd)
build_dir=$(cd "$1" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
/usr/bin/python3 -m venv --system-site-packages "$work/venv"
# From a copy of the package's sources: pip builds in place and must not write into the checkout.
mkdir "$work/pkg"
cp -r "$source_dir/python/pyproject.toml" "$source_dir/python/setup.py" "$source_dir/python/peha" "$work/pkg/"
PEHA_BUILD_DIR="$build_dir" "$work/venv/bin/pip" install --no-build-isolation --no-deps --no-index -q "$work/pkg"
cd "$work"
"$work/venv/bin/python" - "$source_dir" "$work/venv" <<'PY'
import pathlib, sys
import peha
source, venv = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
assert pathlib.Path(peha.__file__).resolve().is_relative_to(venv.resolve()), peha.__file__
rig = peha.Rig(str(source / "configs" / "e1_one_dof.yaml"))
force_N = peha.forward_force(rig.joint.agonist.pam, 3e5, 0.1)
assert 500.0 < force_N < 5000.0, force_N
try:
    peha.forward_force(rig.joint.agonist.pam, 0.3, 0.1)
    raise SystemExit("0.3 Pa was accepted")
except ValueError as e:
    assert "MPa given as Pa" in str(e), e
print(f"peha {peha.__file__}: forward_force(0.3 MPa, eps 0.1) = {force_N:.1f} N; 0.3 refused")
PY
