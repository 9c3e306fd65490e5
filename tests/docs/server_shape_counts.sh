#!/bin/bash
# Counts for issue 34 (the server's shape), by command; run from the repository root: each section prints its command and its output. Not a test: the closing notes quote its before and after.
# Needs universal-ctags (apt-get install universal-ctags) for the longest functions.
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
echo "== longest functions in backend/server (lines; ctags -R --kinds-C++=f --fields=+ne)"
ctags -R --languages=C++ --kinds-C++=f --fields=+ne -o - backend/server | awk -F'\t' '{s="";e="";for(i=4;i<=NF;i++){if($i~/^line:/)s=substr($i,6);if($i~/^end:/)e=substr($i,5)} if(e!="")print e-s+1, $2":"s, $1}' | sort -rn | head -5
echo "== GAP pairs: places that bound the count of pairs"
grep -rnE "pairs\"\]\.size\(\) > |json_array\(request\[\"pairs\"\]|too_many_pairs" backend/server/src backend/gap/src python/src 2>/dev/null
echo "== GAP max_iter: places that bound it"
grep -rnE "max_iter (>|<) |max_iter must|> (lim|limits)\.max_gap_iterations" backend python/src 2>/dev/null
echo "== sigma: places that validate a sigma edit (terms, sum), from request to field"
grep -rnE "kelvin::weld_sigma\(|[^_]validate\(sigma|require_sigma_in_range\(|sigma_value\(s\.|validate\(user" backend --include=*.cpp
echo "== literal bounds beside named constants (1000, [0, 1]) in backend/server"
grep -rnE "[^0-9.e]1000[^0-9]|\[0, 1\]" backend/server/src backend/server/include --include=*.cpp --include=*.hpp | grep -v "1000000\|^.*//"
echo "== kMax* constants outside the limits table (definitions)"
grep -rnE "constexpr[^=]*\bkMax[A-Za-z]* *=" backend python/src 2>/dev/null | grep -v "server/config.hpp"
echo "count: $(grep -rnE "constexpr[^=]*\bkMax[A-Za-z]* *=" backend python/src 2>/dev/null | grep -v server/config.hpp | wc -l) in $(grep -rlE "constexpr[^=]*\bkMax[A-Za-z]* *=" backend python/src 2>/dev/null | grep -v server/config.hpp | wc -l) files"
echo "== FNV-1a claims"
grep -rn "FNV" backend docs README.md python/distlab web/src/core/wire.gen.ts 2>/dev/null
echo "== state vocabularies (an enum, or state strings assigned)"
grep -rnE "enum class [A-Za-z]*State" backend/server
grep -rlE "(state|fields_state) = \"[a-z]+\"|state = [a-z.]*\? \"" backend/server --include=*.cpp
echo "== exception-to-error mappers (catch InvalidInput then build an invalid_input answer)"
grep -rn -A4 "catch (const InvalidInput" backend/server --include=*.cpp | grep "invalid_input" 
echo "== CBF rollout cancel (flag vs Cancelled)"
grep -rnE "cancelled = true|rec\.cancelled|record->cancelled" backend/cbf backend/server --include=*.cpp | head
echo "== prepared-field key: functions that hash a surface with the preparation options (definitions)"
grep -rnE "^std::string (prepare_key|content_key|surface_hash)\(" backend --include=*.cpp
echo "== marching tetrahedra implementations (a tetrahedron's one-corner / two-corner split)"
grep -rnE "ni == 1|n_in == 1|ni == 2" backend --include=*.cpp --include=*.hpp
echo "== sigma summation (constant + per-vertex + terms at a point) outside/inside numerics"
grep -rnE "(kelvin::)?evaluate\(sigma, x" backend --include=*.cpp
echo "== include graph of backend/server"
python3 - <<'PY'
import os,re
root='backend/server'
files=[os.path.join(d,f) for d,_,fs in os.walk(root) for f in fs if f.endswith(('.cpp','.hpp'))]
feat_hdr={'gap_json.hpp','kelvin_json.hpp','kelvin_objects.hpp','cbf_json.hpp','cbf_rollouts.hpp','robot_json.hpp'}
def feature(p):
    parts=p.split('/')
    if 'src' in parts and len(parts)>parts.index('src')+2: return parts[parts.index('src')+1]
    b=os.path.basename(p)
    if b in feat_hdr: return b.split('_')[0]
    return None
byname={}
for f in files: byname.setdefault(os.path.basename(f),[]).append(f)
edges=[]
for f in files:
    for line in open(f):
        m=re.match(r'#include "([^"]+)"',line)
        if not m: continue
        inc=m.group(1)
        cand=os.path.normpath(os.path.join(os.path.dirname(f),inc))
        if inc.startswith('distlab/server/'): cand=os.path.join(root,'include',inc)
        if os.path.exists(cand) and cand.startswith(root): edges.append((f,cand))
core_feat=[(a,b) for a,b in edges if feature(a) is None and feature(b) is not None]
between=[(a,b) for a,b in edges if feature(a) and feature(b) and feature(a)!=feature(b)]
print(f"files {len(files)}, edges {len(edges)}, core->feature {len(core_feat)}, feature->other feature {len(between)}")
for a,b in core_feat+between: print("  ",a,"->",b)
PY
