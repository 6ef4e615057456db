#!/usr/bin/env bash
# Bad input to `voxlab truth`: each case must fail with a message naming the file and the field,
# exit non-zero, and leave no output file behind.
. "$(dirname "$0")/lib.sh"
T=$TEST_TMP
out=$T/out.exr

good_scene() { # $1 = file, $2 = objects JSON, $3 = extra top-level fields
  cat >"$1" <<JSON
{"name": "t", "size": [8, 8], ${3:-} "camera": {"position": [0, 3, 3], "look_at": [0, 0, 0], "fov_deg": 40},
 "lights": [{"type": "directional", "direction": [0, 1, 0], "irradiance": [3, 3, 3]}],
 "materials": {"grey": {"color": [0.5, 0.5, 0.5]}},
 "objects": $2}
JSON
}
quad='[{"ply": "quad.ply", "material": "grey"}]'
cat >"$T/quad.ply" <<'PLY'
ply
format ascii 1.0
element vertex 4
property float x
property float y
property float z
element face 1
property list uchar int vertex_indices
end_header
-1 0 -1
-1 0 1
1 0 1
1 0 -1
4 0 1 2 3
PLY

# Each case: the scene file, the pattern its message must match.
expect_error() { # name pattern scene [extra args]
  local name=$1 pattern=$2 scene=$3; shift 3
  rm -f "$out"
  check_fails "$name" "$pattern" "$VOXLAB" truth "$scene" --spp 1 -o "$out" "$@"
  if [ -e "$out" ] || ls "$T"/out.exr.tmp.* >/dev/null 2>&1; then
    echo "not ok $name-no-output: an output file was left behind"
    failures=$((failures + 1))
  else
    echo "ok $name-no-output"
  fi
}

expect_error missing_file "nonexistent\.json.*cannot open" "$T/nonexistent.json"

printf '{"name": "t", "size": [8, 8],\n "camera": {"position": [0, 1, 2]\n' >"$T/malformed.json"
expect_error malformed_json "malformed\.json: malformed JSON near line" "$T/malformed.json"

good_scene "$T/wrong_type.json" "$quad" '"background": "blue",'
expect_error wrong_type "wrong_type\.json.*background.*expected an array of 3 numbers" "$T/wrong_type.json"

good_scene "$T/wrong_type2.json" "$quad" '"effects": "shadows",'
expect_error wrong_type_effects "wrong_type2\.json.*effects.*expected an array" "$T/wrong_type2.json"

good_scene "$T/unknown_effect.json" "$quad" '"effects": ["shadows", "caustics"],'
expect_error unknown_effect "unknown_effect\.json.*effects\[1\].*caustics" "$T/unknown_effect.json"

good_scene "$T/unknown_field.json" "$quad" '"efects": ["shadows"],'
expect_error unknown_field "unknown_field\.json.*unknown field \"efects\"" "$T/unknown_field.json"

good_scene "$T/no_tris.json" '[{"gltf": "'"$REPO"'/tests/data/points.gltf", "material": "grey"}]'
expect_error gltf_without_triangles "no_tris\.json.*objects\[0\].*points\.gltf.*no triangle" "$T/no_tris.json"

good_scene "$T/nan.json" '[{"ply": "'"$REPO"'/tests/data/nan_vertex.ply", "material": "grey"}]'
expect_error nan_vertex "nan\.json.*objects\[0\].*nan_vertex\.ply.*non-finite" "$T/nan.json"

good_scene "$T/missing_mesh.json" '[{"ply": "gone.ply", "material": "grey"}]'
expect_error missing_mesh "missing_mesh\.json.*objects\[0\].*gone\.ply" "$T/missing_mesh.json"

good_scene "$T/unknown_material.json" '[{"ply": "quad.ply", "material": "gold"}]'
expect_error unknown_material "unknown_material\.json.*objects\[0\].*unknown material \"gold\"" "$T/unknown_material.json"

good_scene "$T/size0.json" "$quad"
sed -i 's/"size": \[8, 8\]/"size": [0, 8]/' "$T/size0.json"
expect_error size_zero "size0\.json\.size: 0x8 is not a valid image size" "$T/size0.json"

good_scene "$T/size_huge.json" "$quad"
sed -i 's/"size": \[8, 8\]/"size": [100000, 100000]/' "$T/size_huge.json"
expect_error size_huge "size_huge\.json\.size: 100000x100000 is not a valid image size" "$T/size_huge.json"

good_scene "$T/far_camera.json" "$quad"
sed -i 's/"position": \[0, 3, 3\]/"position": [0, 2.9e38, 3]/' "$T/far_camera.json"
expect_error camera_out_of_range "far_camera\.json: camera\.position: \(0, 2\.9e\+38, 3\) is out of range" "$T/far_camera.json"

good_scene "$T/ok.json" "$quad"
expect_error size_option_zero "--size 0x0: expected WxH" "$T/ok.json" --size 0x0
expect_error spp_zero "--spp 0: expected an integer from 1" "$T/ok.json" --spp 0

# Unwritable output: a directory that does not exist, and a read-only one.
check_fails unwritable_missing_dir "nodir/out\.exr: cannot write" "$VOXLAB" truth "$T/ok.json" --spp 1 -o "$T/nodir/out.exr"
mkdir -p "$T/ro" && chmod 555 "$T/ro"
if [ "$(id -u)" -ne 0 ]; then
  check_fails unwritable_readonly_dir "ro/out\.exr: cannot write" "$VOXLAB" truth "$T/ok.json" --spp 1 -o "$T/ro/out.exr"
else
  # root ignores directory permissions; a path through a regular file is unwritable for anyone.
  check_fails unwritable_through_file "quad\.ply/out\.exr: cannot write" "$VOXLAB" truth "$T/ok.json" --spp 1 -o "$T/quad.ply/out.exr"
fi
check_fails unknown_extension "out\.bmp.*(\.exr|extension)" "$VOXLAB" truth "$T/ok.json" --spp 1 -o "$T/out.bmp"
[ -e "$T/out.bmp" ] && { echo "not ok unknown_extension-no-output"; failures=$((failures + 1)); } || echo "ok unknown_extension-no-output"

# Zero-area triangles are dropped and counted, not an error.
cat >"$T/degenerate.ply" <<'PLY'
ply
format ascii 1.0
element vertex 5
property float x
property float y
property float z
element face 3
property list uchar int vertex_indices
end_header
-1 0 -1
-1 0 1
1 0 1
0 0 0
2 0 2
3 0 1 2
3 0 3 3
3 0 3 4
PLY
good_scene "$T/degenerate.json" '[{"ply": "degenerate.ply", "material": "grey"}]'
check degenerate_renders "$VOXLAB" truth "$T/degenerate.json" --spp 1 -o "$T/deg.exr" --stats "$T/deg.json"
check degenerate_counted grep -q '"degenerate_triangles":[[:space:]]*2' "$T/deg.json"
check degenerate_kept_one grep -q '"triangles":[[:space:]]*1,' "$T/deg.json"
finish
