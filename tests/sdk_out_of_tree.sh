#!/usr/bin/env bash
# The plugin author's path, end to end: install locsim to a temporary prefix, write a skeleton
# with `locsim new-plugin`, build it out of tree against the installed SDK, list it, and run it
# next to a built-in filter on the demo world. Then the installed Python parts: a localizer in
# Python by name, `import locsim` from the install, and (when python3 can load it) locsim.World
# with a rendered camera, each finding the others by the installed layout alone.
set -euo pipefail
build_dir=$1
source_dir=$2
python=${3:-python3}
world_loads=${4:-1}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cmake --install "$build_dir" --prefix "$work/prefix" >/dev/null
locsim="$work/prefix/bin/locsim"
"$locsim" new-plugin my_filter "$work/my_filter"
# As docs/plugins.md says to, with no build type: the plugin must still be optimised (at -O0 a
# filter's update cost 250x more).
cmake -S "$work/my_filter" -B "$work/my_filter/build" -DCMAKE_PREFIX_PATH="$work/prefix" \
  -DCMAKE_EXPORT_COMPILE_COMMANDS=ON >/dev/null
cmake --build "$work/my_filter/build" >/dev/null
grep '"command"' "$work/my_filter/build/compile_commands.json" | grep -q -- ' -O[23] ' || {
  echo "the skeleton is not built optimised without a build type:" >&2
  grep '"command"' "$work/my_filter/build/compile_commands.json" >&2
  exit 1
}
export LOCSIM_PLUGIN_PATH="$work/my_filter/build"
# Capture first: `grep -q` stops reading at its match, and under pipefail the writer's SIGPIPE
# would fail the test once the listing outgrows the pipe buffer.
listing=$("$locsim" plugins)
grep -q "^my_filter " <<<"$listing"
grep -q "^odometry " <<<"$listing"   # the installed built-ins are found from the prefix
grep -q "^python:landmark_pf " <<<"$listing"   # so are the installed Python examples
"$locsim" run "$source_dir/worlds/demo/demo.yaml" --duration 5 --out "$work/run" -q \
  --localizer my_filter:gain=0.2 --localizer odometry --localizer python:landmark_pf:particles=200
test -s "$work/run/my_filter.tum"
test "$(grep -c '"status": "ok"' "$work/run/metrics.json")" -eq 3

# The installed package, not the source tree's (which Debian's python3 sees through locsim.pth):
# it drives the installed binary, loads that run, and steps the installed module's world.
env -u LOCSIM_BINARY -u LOCSIM_RENDER_MODULE -u LOCSIM_PYTHON_EXTENSION_DIR \
  PYTHONPATH="$work/prefix/share/locsim/python" PYTHONDONTWRITEBYTECODE=1 \
  "$python" - "$work" "$source_dir" "$world_loads" <<'PY'
import os, sys
work, source, world_loads = sys.argv[1], sys.argv[2], sys.argv[3] == "1"
import locsim
prefix = os.path.join(work, "prefix")
assert locsim.__file__.startswith(prefix), locsim.__file__
assert locsim.binary() == os.path.join(prefix, "bin", "locsim"), locsim.binary()
run = locsim.load_run(os.path.join(work, "run"))
assert len(run.errors()) > 0
if world_loads:
    world = locsim.World(os.path.join(source, "worlds/asrl/field_rendered.yaml"), seed=2, duration=1.0)
    world.run_until(1.0)
    module = sys.modules["_locsim_world"].__file__
    assert module.startswith(prefix), module
    shots = [r for r in world.readings() if r["sensor"] == "ptz_camera"]
    assert shots, "the rendered camera took no pictures"
PY

# The particle-filter example of docs/plugins.md, as printed there, built against the installed
# skeleton (locsim/particle_filter.hpp) and run on paper 004's field.
"$locsim" new-plugin my_mcl "$work/my_mcl" >/dev/null
{
  printf '#include <locsim/localizer.hpp>\n#include <locsim/particle_filter.hpp>\n'
  printf 'namespace sdk = locsim::sdk;\n'
  sed -n '/^class MyMcl final/,/^```/p' "$source_dir/docs/plugins.md" | sed '$d'
  printf 'constexpr locsim_param_decl kParams[] = {{"unused", LOCSIM_PARAM_INT, 0, 0, 1, nullptr, "-"}};\n'
  printf 'LOCSIM_LOCALIZER(MyMcl, "my_mcl", "docs/plugins.md example", kParams)\n'
} >"$work/my_mcl/my_mcl.cpp"
cmake -S "$work/my_mcl" -B "$work/my_mcl/build" -DCMAKE_PREFIX_PATH="$work/prefix" \
  -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$work/my_mcl/build" >/dev/null
LOCSIM_PLUGIN_PATH="$work/my_mcl/build" "$locsim" run "$source_dir/worlds/asrl/field.yaml" \
  --duration 10 --out "$work/run_mcl" -q --localizer my_mcl
grep -q '"status": "ok"' "$work/run_mcl/metrics.json"
echo "out-of-tree plugins built against the installed SDK and ran"
