# Sourced at the start of every GPU-machine command: installs the carried wheels (.whl/) and the
# warp-lang wheel assembled from the parts sent before (/tmp/wl, see ../shared/gpu/fetch-warp.sh)
# once per machine, and points the caches at the machine's /tmp.
if [ ! -f /tmp/site/.ready ]; then
  # Byte-compiled at install, as a user's pip install leaves them (start-up counts imports).
  python3 -m pip install -q --no-index --no-deps --no-cache-dir --upgrade \
    --target /tmp/site .whl/*.whl || return 1
  if ls /tmp/wl/? >/dev/null 2>&1; then
    cat /tmp/wl/? > /tmp/wl/warp_lang-1.19.0-py3-none-manylinux_2_28_x86_64.whl &&
      python3 -m pip install -q --no-index --no-deps --target /tmp/site \
        /tmp/wl/warp_lang-*.whl || return 1
  fi
  touch /tmp/site/.ready
fi
export PYTHONPATH=/tmp/site:$PWD PYTHONUNBUFFERED=1 QUADCOS_CACHE_DIR=${QUADCOS_CACHE_DIR:-/tmp/qcache}
