#!/usr/bin/env bash
# Installs the oracle libraries the tests compare against: PCL 1.13 (Debian libpcl-dev),
# Open3D 0.20 (pip open3d-cpu), scikit-fem and OpenCV (headless), plus their run-time
# libraries. Idempotent: packages already present at the pinned versions are left alone,
# so a second run only checks and exits. Fails loudly on any error.
#
# Usage: tools/oracle/install.sh            (as root, or with sudo available)
# Env:   PYTHON=python3.11 to choose the interpreter the Open3D oracle will run under.
set -euo pipefail

PYTHON="${PYTHON:-python3}"

# Debian packages: PCL headers + libs for tools/oracle/pcl_oracle.cpp, a compiler, and the
# run-time libraries the open3d-cpu wheel links against (ldd of libOpen3D.so.0.20:
# libGL/libEGL/libX11 via libgl1 libegl1 libx11-6, libusb-1.0, libgomp).
APT_PACKAGES=(libpcl-dev g++ pkg-config libusb-1.0-0 libgomp1 libgl1 libegl1 libx11-6)

# pip packages at the versions verified on the reference machine (Debian 12, Python 3.11).
# gmsh is not an oracle: it is `softsense model new`'s mesher, which its tests need.
PIP_PACKAGES=(open3d-cpu==0.20.0 scikit-fem==12.0.2 opencv-python-headless==5.0.0.93 gmsh==4.15.2)

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
    SUDO="sudo"
fi

missing=()
for p in "${APT_PACKAGES[@]}"; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
        missing+=("$p")
    fi
done
if [ "${#missing[@]}" -gt 0 ]; then
    echo "install.sh: apt-get install ${missing[*]}"
    $SUDO env DEBIAN_FRONTEND=noninteractive apt-get update -q
    $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}"
else
    echo "install.sh: apt packages present (${APT_PACKAGES[*]})"
fi

pcl_version="$(pkg-config --modversion pcl_common)"
case "$pcl_version" in
    1.13.*) echo "install.sh: PCL $pcl_version" ;;
    *) echo "install.sh: PCL $pcl_version found, the oracle semantics are pinned to 1.13" >&2; exit 1 ;;
esac

pip_missing=()
for spec in "${PIP_PACKAGES[@]}"; do
    name="${spec%%==*}"
    want="${spec##*==}"
    have="$("$PYTHON" -m pip show "$name" 2>/dev/null | sed -n 's/^Version: //p' || true)"
    if [ "$have" != "$want" ]; then
        pip_missing+=("$spec")
    fi
done
if [ "${#pip_missing[@]}" -gt 0 ]; then
    echo "install.sh: pip install ${pip_missing[*]}"
    # PIP_BREAK_SYSTEM_PACKAGES: Debian's system Python refuses pip installs otherwise;
    # harmless for a virtualenv or pyenv interpreter.
    PIP_BREAK_SYSTEM_PACKAGES=1 "$PYTHON" -m pip install -q --disable-pip-version-check "${pip_missing[@]}"
else
    echo "install.sh: pip packages present (${PIP_PACKAGES[*]})"
fi

# Prove the oracles import and report their versions.
"$PYTHON" - <<'PY'
import open3d, skfem, cv2
assert open3d.__version__ == "0.20.0", open3d.__version__
print(f"install.sh: open3d {open3d.__version__}, scikit-fem {skfem.__version__}, opencv {cv2.__version__}")
PY
