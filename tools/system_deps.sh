#!/usr/bin/env bash
# Installs the Debian packages the project needs when they are missing and we may install them:
# mesa-vulkan-drivers (a software Vulkan driver, so GGUI renders headless without a GPU) and
# xvfb/xauth (a virtual display for the real-window viewer test). Without root or apt it only
# says what is missing: the rasteriser renderer needs no Vulkan, and window tests skip.
set -u
need=()
ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1 || ls /usr/share/vulkan/icd.d/*.json >/dev/null 2>&1 \
  || need+=(mesa-vulkan-drivers libvulkan1)
command -v xvfb-run >/dev/null 2>&1 || need+=(xvfb xauth)
[ ${#need[@]} -eq 0 ] && exit 0
if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
  echo "installing Debian packages: ${need[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq >/dev/null && apt-get install -y -qq --no-install-recommends "${need[@]}" >/dev/null \
    || echo "warning: could not install ${need[*]}; headless GGUI and window tests will be skipped"
else
  echo "note: missing ${need[*]} (run as root with apt to install); the raster renderer still works"
fi
exit 0
