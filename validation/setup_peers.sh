#!/usr/bin/env bash
# Installs the peer harness of ../shared/peers (scikit-fem, CHOLMOD via scikit-sparse, PyMFEM)
# into a virtual environment outside the repository, for validation/side_by_side.py.
# Debian 12: CHOLMOD 3 (SuiteSparse 5.12) with OpenBLAS; scikit-sparse 0.4.16 (0.5 needs CHOLMOD 5).
set -euo pipefail
VENV=${TETFEM_PEERS_VENV:-/work/peers-venv}
apt-get update -qq
apt-get install -y -qq libsuitesparse-dev libopenblas0-pthread
python3 -m venv "$VENV"
"$VENV/bin/pip" install -q numpy scipy scikit-fem "scikit-sparse==0.4.16" mfem matplotlib
echo "peers ready: $VENV/bin/python"
