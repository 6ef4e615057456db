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

# One JSON document, each key once (json_util.h's json_parse_strict): cJSON alone stops at the
# document's end and finds the first of two values, where other readers take the last.
good_scene "$T/trail.json" "$quad"
printf ' garbage' >>"$T/trail.json"
expect_error trailing_garbage "trail\.json: line 5: text after the JSON document \(\"garbage\"\): expected the end" "$T/trail.json"
good_scene "$T/second_doc.json" "$quad"
printf '\n{}\n' >>"$T/second_doc.json"
expect_error second_document "second_doc\.json: line 6: text after the JSON document" "$T/second_doc.json"
good_scene "$T/nul_byte.json" "$quad"
printf '\0{}' >>"$T/nul_byte.json"
expect_error nul_byte "nul_byte\.json: byte [0-9]+ is a NUL: expected JSON text" "$T/nul_byte.json"
good_scene "$T/dup_fov.json" "$quad"
sed -i 's/"fov_deg": 40/"fov_deg": 40, "fov_deg": "x"/' "$T/dup_fov.json"
expect_error duplicate_key "dup_fov\.json: camera\.fov_deg appears twice: expected each key once" "$T/dup_fov.json"
good_scene "$T/dup_top.json" "$quad" '"size": [16, 16],'
expect_error duplicate_top_key "dup_top\.json: size appears twice" "$T/dup_top.json"
good_scene "$T/dup_deep.json" '[{"ply": "quad.ply", "material": "grey"},
  {"ply": "quad.ply", "material": "grey", "transform": {"scale": 2, "translate": [0, 1, 0], "scale": 3}}]'
expect_error duplicate_nested_key "dup_deep\.json: objects\[1\]\.transform\.scale appears twice" "$T/dup_deep.json"
sed 's/^{"asset"/{"scene": 0, "asset"/' "$REPO/tests/data/quad.gltf" >"$T/dup.gltf"
good_scene "$T/dup_gltf.json" '[{"gltf": "dup.gltf", "material": "grey"}]'
expect_error duplicate_gltf_key "dup_gltf\.json: objects\[0\]\.gltf: .*dup\.gltf: scene appears twice" "$T/dup_gltf.json"
good_scene "$T/trail_ws.json" "$quad"
printf '  \n\t\r\n' >>"$T/trail_ws.json"
check trailing_whitespace_loads "$VOXLAB" truth "$T/trail_ws.json" --spp 1 -o "$T/ws.exr"

# Fields that conflict, or that only another kind of object reads, are refused rather than one of
# them dropped without a word.
good_scene "$T/ply_and_obj.json" '[{"ply": "quad.ply", "obj": "gone.obj", "material": "grey"}]'
expect_error ply_and_obj "ply_and_obj\.json: objects\[0\]: has both \"ply\" and \"obj\": expected one mesh source" "$T/ply_and_obj.json"
good_scene "$T/gen_and_gltf.json" '[{"generator": "spheres", "gltf": "gone.gltf", "material": "grey"}]'
expect_error generator_and_gltf "gen_and_gltf\.json: objects\[0\]: has both \"generator\" and \"gltf\"" "$T/gen_and_gltf.json"
good_scene "$T/ply_seed.json" '[{"ply": "quad.ply", "material": "grey", "seed": 3}]'
expect_error ply_with_seed "ply_seed\.json: objects\[0\]: a ply object has \"seed\": expected it only with \"generator\"" "$T/ply_seed.json"
good_scene "$T/ply_uris.json" '[{"ply": "quad.ply", "material": "grey", "uris_outside_folder": true}]'
expect_error ply_with_uris "ply_uris\.json: objects\[0\]: a ply object has \"uris_outside_folder\": expected it only with \"gltf\"" "$T/ply_uris.json"
good_scene "$T/cam_both.json" "$quad"
sed -i 's/"fov_deg": 40/"fov_deg": 40, "orbit": {"distance": 4}/' "$T/cam_both.json"
expect_error camera_position_and_orbit "cam_both\.json: camera: has both \"position\" and \"orbit\": expected one of them" "$T/cam_both.json"
good_scene "$T/dir_intensity.json" "$quad"
sed -i 's/"irradiance": \[3, 3, 3\]/"irradiance": [3, 3, 3], "intensity": [9, 9, 9]/' "$T/dir_intensity.json"
expect_error directional_with_intensity "dir_intensity\.json: lights\[0\]: a directional light has \"intensity\": expected \"direction\" and \"irradiance\"" "$T/dir_intensity.json"
good_scene "$T/dir_position.json" "$quad"
sed -i 's/"irradiance": \[3, 3, 3\]/"irradiance": [3, 3, 3], "position": [0, 5, 0]/' "$T/dir_position.json"
expect_error directional_with_position "dir_position\.json: lights\[0\]: a directional light has \"position\"" "$T/dir_position.json"
good_scene "$T/point_direction.json" "$quad"
sed -i 's/"type": "directional", "direction": \[0, 1, 0\], "irradiance": \[3, 3, 3\]/"type": "point", "position": [0, 2, 0], "direction": [0, 1, 0]/' "$T/point_direction.json"
expect_error point_with_direction "point_direction\.json: lights\[0\]: a point light has \"direction\": expected \"position\" and \"intensity\"" "$T/point_direction.json"
good_scene "$T/point_irradiance.json" "$quad"
sed -i 's/"type": "directional", "direction": \[0, 1, 0\]/"type": "point", "position": [0, 2, 0]/' "$T/point_irradiance.json"
expect_error point_with_irradiance "point_irradiance\.json: lights\[0\]: a point light has \"irradiance\"" "$T/point_irradiance.json"
good_scene "$T/point_ok.json" "$quad"
sed -i 's/"type": "directional", "direction": \[0, 1, 0\], "irradiance": \[3, 3, 3\]/"type": "point", "position": [0, 2, 0], "intensity": [9, 9, 9]/' "$T/point_ok.json"
check point_light_loads "$VOXLAB" truth "$T/point_ok.json" --spp 1 -o "$T/point.exr"

good_scene "$T/wrong_type.json" "$quad" '"background": "blue",'
expect_error wrong_type "wrong_type\.json.*background.*expected an array of 3 numbers" "$T/wrong_type.json"

good_scene "$T/wrong_type2.json" "$quad" '"effects": "shadows",'
expect_error wrong_type_effects "wrong_type2\.json.*effects.*expected an array" "$T/wrong_type2.json"

good_scene "$T/unknown_effect.json" "$quad" '"effects": ["shadows", "caustics"],'
expect_error unknown_effect "unknown_effect\.json.*effects\[1\].*caustics" "$T/unknown_effect.json"
good_scene "$T/effect_twice.json" "$quad" '"effects": ["shadows", "dof", "shadows"],'
expect_error effect_twice "effect_twice\.json: effects\[2\]: shadows is listed twice" "$T/effect_twice.json"

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
expect_error size_zero "size0\.json: size: 0x8 is not a valid image size" "$T/size0.json"

good_scene "$T/size_huge.json" "$quad"
sed -i 's/"size": \[8, 8\]/"size": [100000, 100000]/' "$T/size_huge.json"
expect_error size_huge "size_huge\.json: size: 100000x100000 is not a valid image size" "$T/size_huge.json"

# A top-level field follows the file as every other field does ("file: field: ..."), not joined
# to the file name by a dot ("bg_neg.json.background").
good_scene "$T/bg_neg.json" "$quad" '"background": [-1, 0, 0],'
expect_error background_negative "bg_neg\.json: background: expected non-negative values" "$T/bg_neg.json"
good_scene "$T/name_number.json" "$quad"
sed -i 's/"name": "t"/"name": 3/' "$T/name_number.json"
expect_error name_not_string "name_number\.json: name: expected a string" "$T/name_number.json"
good_scene "$T/materials_empty.json" "$quad"
sed -i 's/"materials": {.*}},/"materials": {},/' "$T/materials_empty.json"
expect_error materials_empty "materials_empty\.json: materials: expected a non-empty object" "$T/materials_empty.json"

good_scene "$T/far_camera.json" "$quad"
sed -i 's/"position": \[0, 3, 3\]/"position": [0, 2.9e38, 3]/' "$T/far_camera.json"
expect_error camera_out_of_range "far_camera\.json: camera\.position: \(0, 2\.9e\+38, 3\) is out of range" "$T/far_camera.json"

good_scene "$T/ok.json" "$quad"
expect_error size_option_zero "--size 0x0: expected WxH" "$T/ok.json" --size 0x0
expect_error spp_zero "--spp 0: expected an integer from 1" "$T/ok.json" --spp 0
# A model's switch parameter takes 0 or 1 (vicini's extended: 0.5 lay in its range, read as off).
check_fails switch_param_half "--param extended=0\.5: extended is a switch: expected 0 or 1" \
  "$VOXLAB" bake "$T/ok.json" --model vicini --res 4 --rays 8 --param extended=0.5 -o "$T/half.vox"
check switch_param_one "$VOXLAB" bake "$T/ok.json" --model vicini --res 4 --rays 8 --param extended=1 -o "$T/one.vox"

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

# An output that names an input (the scene file, its mesh, --vox, compare's images) or another
# output is refused before any work, and the file is left as it was: these runs once replaced the
# scene with the statistics, the mesh with .vox data, image A with the heat map, and exited 0.
same_bytes() { # name file copy (put back after a failure, so that each case stands alone)
  if cmp -s "$2" "$3"; then echo "ok $1"; else echo "not ok $1: $2 was overwritten"; failures=$((failures + 1)); cp "$3" "$2"; fi
}
C=$T/clash && mkdir -p "$C" && cp "$T/quad.ply" "$C/quad.ply" && cp "$T/quad.ply" "$C/quad.orig"
good_scene "$C/s.json" "$quad" && cp "$C/s.json" "$C/s.orig"
check_fails clash_stats_is_scene "^voxlab truth: --stats $C/s\.json is the scene file: refusing to overwrite an input" \
  "$VOXLAB" truth "$C/s.json" --spp 1 -o "$C/x.exr" --stats "$C/s.json"
same_bytes clash_stats_is_scene-kept "$C/s.json" "$C/s.orig"
check_fails clash_stats_is_scene_render "--stats $C/\./s\.json is the scene file \($C/s\.json\)" \
  "$VOXLAB" render "$C/s.json" --model binary --res 8 -o "$C/x.exr" --stats "$C/./s.json"
same_bytes clash_stats_is_scene_render-kept "$C/s.json" "$C/s.orig"
ln -sf quad.ply "$C/mesh_link.vox" # a link to the mesh is the mesh
check_fails clash_o_is_mesh "^voxlab bake: -o $C/mesh_link\.vox is the scene's objects\[0\]\.ply \($C/quad\.ply\): refusing" \
  "$VOXLAB" bake "$C/s.json" --model binary --res 8 -o "$C/mesh_link.vox"
same_bytes clash_o_is_mesh-kept "$C/quad.ply" "$C/quad.orig"
"$VOXLAB" bake "$C/s.json" --model binary --res 8 --rays 4 -o "$C/a.vox" && cp "$C/a.vox" "$C/a.orig"
ln -sf a.vox "$C/a_link.json"
check_fails clash_stats_is_vox "^voxlab render: --stats $C/a_link\.json is the --vox file \($C/a\.vox\)" \
  "$VOXLAB" render "$C/s.json" --model binary --vox "$C/a.vox" -o "$C/x.exr" --stats "$C/a_link.json"
same_bytes clash_stats_is_vox-kept "$C/a.vox" "$C/a.orig"
"$VOXLAB" truth "$C/s.json" --spp 1 --size 16x16 -o "$C/A.exr" && cp "$C/A.exr" "$C/A.orig" && cp "$C/A.exr" "$C/B.exr"
check_fails clash_heatmap_is_a "^voxlab compare: --heatmap $C/A\.exr is image A: refusing to overwrite an input" \
  "$VOXLAB" compare "$C/A.exr" "$C/B.exr" --heatmap "$C/A.exr"
same_bytes clash_heatmap_is_a-kept "$C/A.exr" "$C/A.orig"
# Two outputs, one file (here through a link): one of them would be lost.
ln -sf A.exr "$C/A_link.json"
check_fails clash_stats_is_o "^voxlab truth: --stats $C/A_link\.json is the same file as -o $C/A\.exr: refusing to write two" \
  "$VOXLAB" truth "$C/s.json" --spp 1 -o "$C/A.exr" --stats "$C/A_link.json"
same_bytes clash_stats_is_o-kept "$C/A.exr" "$C/A.orig"
# A glTF's external files (its buffer, its texture) are inputs too: a truth's or a render's -o naming the
# texture would have replaced it. The quad fixture with its buffer moved into quad.bin and an
# external PNG texture (any PNG: here a truth image) named by its material.
G=$T/clash_gltf && mkdir -p "$G"
"$VOXLAB" truth "$C/s.json" --spp 1 --size 4x4 -o "$G/tex.png" && cp "$G/tex.png" "$G/tex.orig"
/usr/bin/python3 - "$(dirname "$0")/data/quad.gltf" "$G" <<'PY'
import base64, json, sys
g = json.load(open(sys.argv[1]))
data = base64.b64decode(g["buffers"][0]["uri"].split(",", 1)[1])
open(sys.argv[2] + "/quad.bin", "wb").write(data)
g["buffers"][0]["uri"] = "quad.bin"
g["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
g["textures"] = [{"source": 0}]
g["images"] = [{"uri": "tex.png"}]
json.dump(g, open(sys.argv[2] + "/quad.gltf", "w"))
PY
good_scene "$G/s.json" '[{"gltf": "quad.gltf", "material": "grey"}]' '"effects": ["textures"],'
check_fails clash_o_is_gltf_texture "^voxlab truth: -o $G/tex\.png is the scene's objects\[0\]\.gltf \(a file it names\): refusing to overwrite an input" \
  "$VOXLAB" truth "$G/s.json" --spp 1 -o "$G/tex.png"
same_bytes clash_o_is_gltf_texture-kept "$G/tex.png" "$G/tex.orig"
check_fails clash_render_o_is_gltf_texture "^voxlab render: -o \./tex\.png is the scene's objects\[0\]\.gltf \(a file it names\)[ :].*refusing to overwrite an input" \
  bash -c "cd '$G' && '$VOXLAB' render s.json --model alpha --res 8 -o ./tex.png"
same_bytes clash_render_o_is_gltf_texture-kept "$G/tex.png" "$G/tex.orig"
# --frames: every numbered output is checked (here frame 1's image would replace the mesh).
cp "$C/quad.ply" "$C/seq_0001.exr" && cp "$C/quad.ply" "$C/seq.orig"
good_scene "$C/seq.json" '[{"ply": "seq_0001.exr", "material": "grey"}]' '"frames": [0, 2],'
check_fails clash_frame_is_mesh "^voxlab truth: -o $C/seq_0001\.exr is the scene's objects\[0\]\.ply: refusing" \
  "$VOXLAB" truth "$C/seq.json" --spp 1 --frames 0:2 -o "$C/seq.exr"
same_bytes clash_frame_is_mesh-kept "$C/seq_0001.exr" "$C/seq.orig"
[ -e "$C/seq_0000.exr" ] && { echo "not ok clash_frame_is_mesh-before_work: frame 0 was written"; failures=$((failures + 1)); } || echo "ok clash_frame_is_mesh-before_work"

# --rays and --param are a bake's: with --vox they are refused, not ignored (--rays once was).
check_fails vox_refuses_rays "^voxlab render: --rays applies to a bake \(--res\); a \.vox file keeps its bake's rays per voxel$" \
  "$VOXLAB" render "$C/s.json" --vox "$C/a.vox" --rays 8 -o "$C/vr.exr"
check_fails vox_refuses_param "^voxlab render: --param applies to a bake \(--res\)" \
  "$VOXLAB" render "$C/s.json" --vox "$C/a.vox" --param extended=1 -o "$C/vr.exr"
[ -e "$C/vr.exr" ] && { echo "not ok vox_refuses-no_output"; failures=$((failures + 1)); } || echo "ok vox_refuses-no_output"

# --threads has one bound in every command (truth's once said 1 to 1048576, the others 1 to 1024).
check_fails threads_bound_truth "^voxlab truth: --threads 2000: expected an integer from 1 to 1024$" \
  "$VOXLAB" truth "$C/s.json" --threads 2000 -o "$C/th.exr"
check_fails threads_bound_render "^voxlab render: --threads 2000: expected an integer from 1 to 1024$" \
  "$VOXLAB" render "$C/s.json" --model binary --res 8 --threads 2000 -o "$C/th.exr"
check_fails threads_bound_bake "^voxlab bake: --threads 2000: expected an integer from 1 to 1024$" \
  "$VOXLAB" bake "$C/s.json" --model binary --res 8 --threads 2000 -o "$C/th.vox"

# --frames: what a later frame's render would refuse is found before the first is rendered, and
# the message names the frame. Here a quad rises past a point light, which from frame 4 on lies
# inside the scene's bounding sphere, where slicemap shadows have no map: the run once wrote frames
# 0-3 (images and stats) and then failed without saying which frame.
anim_scene() { # $1 = file, $2 = shadow method
  cat >"$1" <<JSON
{"name": "t", "size": [8, 8], "effects": ["shadows"], "shadows": {"method": "$2"}, "frames": [0, 5],
 "camera": {"position": [0, 3, 3], "look_at": [0, 0, 0], "fov_deg": 40},
 "lights": [{"type": "point", "position": [0, 20, 0], "intensity": [300, 300, 300]}],
 "materials": {"grey": {"color": [0.5, 0.5, 0.5]}},
 "objects": [{"ply": "$T/quad.ply", "material": "grey"},
             {"ply": "$T/quad.ply", "material": "grey",
              "animation": {"keys": [{"frame": 0, "translate": [0, 0.5, 0]}, {"frame": 5, "translate": [0, 25, 0]}]}}]}
JSON
}
A=$T/anim && mkdir -p "$A/out" && anim_scene "$A/anim.json" slicemap
light_inside="frame 4: $A/anim\.json: lights\[0\]: a point light inside the scene's bounding sphere"
check_fails frames_checked_first_truth "^voxlab truth: $light_inside" \
  "$VOXLAB" truth "$A/anim.json" --spp 1 --frames 0:5 -o "$A/out/t.exr" --stats "$A/out/t.json"
check_fails frames_checked_first_render "^voxlab render: $light_inside" \
  "$VOXLAB" render "$A/anim.json" --model alpha --res 8 --spp 1 --frames 0:5 -o "$A/out/r.exr" --stats "$A/out/r.json"
check_fails frames_checked_first_split8 "^voxlab render: $light_inside" \
  "$VOXLAB" render "$A/anim.json" --model alpha --res 8 --spp 1 --frames 0:5 --filter split8 -o "$A/out/s.exr"
check_fails frames_checked_first_one_frame "^voxlab truth: frame 5: $A/anim\.json: lights\[0\]" \
  "$VOXLAB" truth "$A/anim.json" --spp 1 --frame 5 -o "$A/out/f5.exr"
# Up front, not on reaching the frame: even --dry-run, which renders nothing, is refused.
check_fails frames_checked_first_dry_run "^voxlab render: $light_inside" \
  "$VOXLAB" render "$A/anim.json" --model alpha --res 8 --spp 1 --frames 0:5 --dry-run -o "$A/out/d.exr"
left=$(ls -A "$A/out")
[ -z "$left" ] && echo "ok frames_checked_first-nothing_written" || { echo "not ok frames_checked_first-nothing_written: $left"; failures=$((failures + 1)); }
check frames_before_the_light_render "$VOXLAB" truth "$A/anim.json" --spp 1 --frames 0:3 -o "$A/out/ok.exr"

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
