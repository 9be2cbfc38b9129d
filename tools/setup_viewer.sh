#!/usr/bin/env bash
# The headless Rerun viewer (tests, docs/img screenshots) renders with Vulkan. Without a GPU that is
# Mesa's software driver lavapipe (Debian: mesa-vulkan-drivers); the viewer's OpenGL fallback
# cannot render headless ("Failed to get render context"). Installs it when missing (root + apt-get),
# otherwise says what to run. A no-op when a Vulkan driver is present.
set -euo pipefail
have_icd() { compgen -G "/usr/share/vulkan/icd.d/*.json" >/dev/null || compgen -G "/etc/vulkan/icd.d/*.json" >/dev/null; }
if have_icd; then
  exit 0
fi
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
  echo "setup_viewer: installing mesa-vulkan-drivers (software Vulkan for the headless Rerun viewer)"
  export DEBIAN_FRONTEND=noninteractive
  apt-get install -y -qq mesa-vulkan-drivers >/dev/null 2>&1 || { apt-get update -qq && apt-get install -y -qq mesa-vulkan-drivers >/dev/null; }
  have_icd && { echo "setup_viewer: ok"; exit 0; }
fi
echo "setup_viewer: no Vulkan driver: the headless Rerun viewer tests will fail." >&2
echo "setup_viewer: install Mesa's lavapipe, e.g. sudo apt-get install mesa-vulkan-drivers" >&2
exit 0
