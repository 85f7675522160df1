#!/usr/bin/env bash
# Writes the robustness battery's bad inputs into DIR (the CTest fixture run_case.sh reads).
set -eu  # (no pipefail: `yes | head` ends yes with SIGPIPE)
d=$1
rm -rf "$d"
mkdir -p "$d"
cd "$d"
tri='v 0 0 0\nv 1 0 0\nv 0 1 0\n'
# Deterministic "random" bytes (an LCG), so that every run tests the same files.
noise() { awk -v n="$1" -v s="$2" 'BEGIN { x = s; for (i = 0; i < n; ++i) { x = (x * 1103515245 + 12345) % 2147483648; printf "%c", 1 + int(x / 65536) % 255 } }'; }
plyhead() { printf 'ply\nformat %s 1.0\nelement vertex %s\nproperty float x\nproperty float y\nproperty float z\nelement face %s\nproperty list uchar int vertex_indices\nend_header\n' "$@"; }

# ---- OBJ
printf "${tri}f /1 2 3\n" >obj_face_slash.obj
printf "${tri}f 0 1 2\n" >obj_face_index0.obj
printf "${tri}f 1 2 9\n" >obj_face_index_big.obj
printf "${tri}f -1 -2 -9\n" >obj_face_negative_big.obj
printf "${tri}f 1 2\n" >obj_face_two.obj
printf "${tri}f 1 2 x\n" >obj_face_word.obj
printf "${tri}f 1 2 3.5\n" >obj_face_float.obj
printf "${tri}f 1x 2 3\n" >obj_face_suffix.obj
printf "${tri}f 99999999999999999999 2 3\n" >obj_face_overflow.obj
printf 'f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n' >obj_face_forward.obj
printf 'v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' >obj_vertex_nan.obj
printf 'v 0 inf 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' >obj_vertex_inf.obj
printf 'v 0 zero 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' >obj_vertex_word.obj
printf 'v 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' >obj_vertex_two.obj
printf 'v 0x1p3 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' >obj_vertex_hex.obj
printf 'v 0 0 0\nv 3e38 0 0\nv 0 3e38 0\nf 1 2 3\n' >obj_extent_3e38.obj
printf 'v -3e38 0 0\nv 3e38 0 0\nv 0 3e38 0\nf 1 2 3\n' >obj_extent_pm3e38.obj
printf 'v 0 0 0\nv 1e10 0 0\nv 0 1 0\nf 1 2 3\n' >obj_vertex_1e10.obj
printf 'v 0 0 0\nv 1e-40 0 0\nv 0 1e-40 0\nf 1 2 3\n' >obj_extent_1e-40.obj
printf 'v 5 5 5\nv 5 5 5\nv 5 5 5\nf 1 2 3\n' >obj_extent_zero.obj
printf 'v 0 0 0\nv 0 0 0\nv 1 0 0\nf 1 2 3\n' >obj_extent_line.obj
printf "${tri}f 1 1 1\nf 2 2 3\n" >obj_degenerate.obj
printf "${tri}" >obj_no_faces.obj
printf '# nothing\n# here\n' >obj_comments.obj
printf "${tri}xyz 1 2\nf 1 2 3\n" >obj_unknown.obj
printf 'v 0 0\0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' >obj_nul.obj
{ printf "${tri}f 1 2 3 "; head -c 70000 /dev/zero | tr '\0' ' '; printf '\n'; } >obj_long_line.obj
{ printf "${tri}f"; for i in $(seq 2000); do printf ' 1'; done; printf '\n'; } >obj_face_2000.obj
noise 4096 1 >obj_random.obj
printf "${tri}f 1 2 3\n" >mesh_bad_ext.stl
: >mesh_empty.off
mkdir -p mesh_dir.obj

# ---- PLY
{ plyhead ascii 4294967296 1; printf '0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n'; } >ply_vertex_2e32.ply
{ plyhead binary_little_endian 4294967296 1; printf '\0\0\0\0'; } >ply_binary_vertex_2e32.ply
{ plyhead ascii 3 4000000000; printf '0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n'; } >ply_face_4e9.ply
{ plyhead ascii 3 1; printf '0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n'; } >ply_face_index_big.ply
{ plyhead ascii 3 1; printf '0 0 0\n1 0 0\n0 1 0\n2 0 1\n'; } >ply_face_two.ply
{ plyhead ascii 3 1; printf '0 0 0\n1 0 0\n0 1 0\n255 0 1 2\n'; } >ply_list_255.ply
{ plyhead ascii 3 1; printf '0 0 0\n1 0 0\n0 1 0\n3 0 1 2.5\n'; } >ply_face_float.ply
{ plyhead ascii 3 1; printf '0 0 0\n1 0 0\n'; } >ply_truncated.ply
{ plyhead binary_little_endian 3 1; printf '\0\0\0\0\0\0\0\0'; } >ply_binary_truncated.ply
{ plyhead ascii 3 1; printf 'nan 0 0\n1 0 0\n0 1 0\n3 0 1 2\n'; } >ply_vertex_nan.ply
{ plyhead ascii 3 1; printf '0 0 0\n3e38 0 0\n0 -3e38 0\n3 0 1 2\n'; } >ply_extent_3e38.ply
{ plyhead binary_big_endian 3 1; printf '\x7f\x80\0\0\0\0\0\0\0\0\0\0' ; printf '\0%.0s' $(seq 24); printf '\x03\0\0\0\0\0\0\0\x01\0\0\0\x02'; } >ply_binary_inf.ply
printf 'ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n' >ply_no_end_header.ply
# An element without properties declaring 10^12 items (found by the ply fuzzer: it was looped
# over, item by item, for minutes), and no vertex element.
printf 'ply\nformat ascii 1.0\nelement junk 1000000000000\nend_header\n-\n' >ply_empty_element_1e12.ply
printf 'ply\nformat utf8 1.0\nelement vertex 3\nend_header\n' >ply_bad_format.ply
printf 'ply\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n' >ply_no_format.ply
printf 'ply\nformat ascii 1.0\nelement vertex 3\nproperty float128 x\nend_header\n' >ply_bad_type.ply
printf 'ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0\n1 0\n0 1\n3 0 1 2\n' >ply_no_z.ply
printf 'ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty int n\nend_header\n0 0 0\n1 0 0\n0 1 0\n3\n' >ply_face_no_list.ply
printf 'ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n3 0 1 2\n0 0 0\n1 0 0\n0 1 0\n' >ply_face_first.ply
printf 'ply\nformat ascii 1.0\nproperty float x\nend_header\n' >ply_property_first.ply
printf 'ply\nformat ascii 1.0\nbogus line\nend_header\n' >ply_unknown_keyword.ply
printf 'ply\nformat ascii 1.0\nelement vertex -1\nend_header\n' >ply_negative_count.ply
printf 'ply\nformat ascii 1.0\nelement vertex 18446744073709551616\nend_header\n' >ply_count_2e64.ply
printf 'ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list float int vertex_indices\nend_header\n' >ply_float_count.ply
{ printf 'ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n'; printf '0 0 0\n1 0 0\n0 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n'; } >ply_two_vertex_elements.ply
printf 'ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n' >ply_no_faces.ply
{ printf 'ply\nformat ascii 1.0\n'; for i in $(seq 2000); do printf 'comment %d\n' "$i"; done; printf 'end_header\n'; } >ply_long_header.ply
{ printf 'ply\nformat ascii 1.0\ncomment '; head -c 70000 /dev/zero | tr '\0' 'x'; printf '\nend_header\n'; } >ply_long_line.ply
printf 'PLY\nformat ascii 1.0\n' >ply_not_ply.ply
{ printf 'ply\n'; noise 225 2; } >ply_random.ply

# ---- OFF
printf 'OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n1000000000 0 1 2\n' >off_face_1e9.off
printf 'OFF\n1000000000 1 0\n0 0 0\n' >off_vertex_1e9.off
printf 'OFF\n1000 1000 0\n0 0 0\n' >off_counts_exceed_file.off
printf 'OFX\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n' >off_bad_header.off
printf 'OFF BINARY\n3 1 0\n' >off_binary.off
printf 'OFF\n3\n0 0 0\n' >off_one_count.off
printf 'OFF\n-3 1 0\n' >off_negative_count.off
printf 'OFF\n3 1 0\n0 0\n1 0 0\n0 1 0\n3 0 1 2\n' >off_vertex_two.off
printf 'OFF\n3 1 0\n0 zero 0\n1 0 0\n0 1 0\n3 0 1 2\n' >off_vertex_word.off
printf 'OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n' >off_face_index_big.off
printf 'OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n' >off_face_two.off
printf 'OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n' >off_face_short_line.off
printf 'OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n' >off_truncated_faces.off
printf 'OFF\n3 1 0\nnan 0 0\n1 0 0\n0 1 0\n3 0 1 2\n' >off_vertex_nan.off
printf 'OFF\n3 1 0\n0 0 0\n1e-40 0 0\n0 1e-40 0\n3 0 1 2\n' >off_extent_1e-40.off
printf 'OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n' >off_no_faces.off
printf 'OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3.0 0 1 2\n' >off_face_float_count.off
{ printf 'OFF\n3 1 0\n0 0 0 '; head -c 70000 /dev/zero | tr '\0' ' '; printf '\n1 0 0\n0 1 0\n3 0 1 2\n'; } >off_long_line.off

# ---- config JSON
{ yes '[' | head -n 60000 | tr -d '\n'; yes ']' | head -n 60000 | tr -d '\n'; } >json_deep_array.json
{ yes '{"a":' | head -n 60000 | tr -d '\n'; printf '1'; yes '}' | head -n 60000 | tr -d '\n'; } >json_deep_object.json
printf '{"shadow.lambda": {"x": {"y": 1}}}' >json_nested3.json
printf '{"ambient": 0.5} trailing' >json_trailing.json
printf '{"ambient": 0.5}{"ambient": 0.6}' >json_two_objects.json
printf '{"world.seed": 9007199254740993}' >json_seed_2p53p1.json
printf '{"world.seed": -1}' >json_seed_negative.json
printf '{"world.seed": 1.5}' >json_seed_fraction.json
printf '{"world.seed": 1e300}' >json_seed_1e300.json
printf '{"world.seed": 18446744073709551616}' >json_seed_2p64.json
printf '[1, 2]' >json_array_top.json
printf '"text"' >json_string_top.json
printf '{"ambient": 0.5, "ambient": 0.6}' >json_duplicate.json
printf '{"ambient": {"v": 0.5}}' >json_object_value.json
printf '{"ambient": null}' >json_null_value.json
printf '{"ambient": [0.5]}' >json_array_value.json
printf '{"lod.cascades": [0, "1"]}' >json_lod_string.json
printf '{"lod.cascades": [0, 1, 3]}' >json_lod_3.json
printf '{"lod.cascades": [0, 1.5]}' >json_lod_float.json
printf '{"lod.cascades": []}' >json_lod_empty.json
printf '{"no.such.key": 1}' >json_unknown_key.json
printf '{"ambient": 0.5' >json_unclosed.json
: >json_empty.json
printf '{"ambient": 0.5} // comment' >json_comment.json
printf '{"ambient": NaN}' >json_nan.json
printf '{"shadow.cascades": " 4"}' >json_space_number.json
printf '{"shadow.cascades": 4.5}' >json_cascades_fraction.json
noise 1024 3 >json_random.json
{ printf '{"x": "'; head -c 1100000 /dev/zero | tr '\0' 'a'; printf '"}'; } >json_big.json
mkdir -p json_dir.json

# ---- output folders
mkdir -p out_locked
echo 1 >out_locked/.csm_flythrough.lock  # pid 1 is alive
# A valid mesh whose LODs take decimation tries: a bumpy 40 x 40 grid (3,200 triangles).
awk 'BEGIN { n = 40; for (j = 0; j <= n; j++) for (i = 0; i <= n; i++)
               printf "v %g %g %g\n", i, 0.3 * sin(i * 0.7) * cos(j * 0.5), j;
             for (j = 0; j < n; j++) for (i = 0; i < n; i++) { a = j * (n + 1) + i + 1;
               printf "f %d %d %d\nf %d %d %d\n", a, a + n + 1, a + 1, a + 1, a + n + 1, a + n + 2 } }' \
  >grid_mesh.obj
