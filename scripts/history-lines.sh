#!/usr/bin/env bash
# Lines of README.md and docs/**/*.md that read as measurement history rather than reference:
# what was before a change, what was tried and dropped, earlier settings, "now X, before Y",
# "(before)" rows, runs "of the same afternoon", "runs interleaved" narratives, old timings.
#
#   scripts/history-lines.sh                 # file:line:text of every matching line
#   scripts/history-lines.sh --count         # matching lines per file, and the total
#   scripts/history-lines.sh --rev HEAD~3    # the same on the files as they were at a commit
#
# The phrases are case-insensitive Perl regular expressions (grep -P), tuned so that ordinary
# reference sentences ("checked before it is read", "messages are dropped", "is used to",
# "views taken before refer to the old arrays", "one driven earlier") do not match.
# Exit status: 0 whether or not lines match; 2 on a usage error.
set -euo pipefail
cd "$(dirname "$0")/.."

PATTERNS=(
    'tried and dropped'
    '\bwhat was (tried|cut|measured and kept)\b'
    '\bwas (tried|added|introduced|removed|replaced|changed)\b'
    '\b(this|that|it) replaced\b|\b(was|were) cut\b|\b(it|they) measured [0-9]'
    '\bearlier (\|u\||encoder|settings?|runs?|colou?rs?|colou?r maps?|measurements?|code|versions?|defaults?|layouts?)(?!\w)'
    '\((before|after)\)'
    '\(before:'
    '\bbefore, (the|[0-9])|\bafter, [0-9]|\bbefore \([0-9]'
    '(^|[,;(]\s*)now\s+[0-9]'
    '[0-9] now\)'
    '\bnow (prints|uses|takes|runs|costs|gives|draws|shows|measures|reads|writes|keeps|sends)\b'
    '\band now\b|\bdrawn now\b'
    '\bbefore (this|that|the|those|these) (two )?changes?\b|\bthe code before\b|\bbefore that[,.]'
    '(?<!is )(?<!are )(?<!be )(?<!been )(?<!being )(?<!was )(?<!were )\bused to\b'
    '\bpreviously\b|\bformerly\b|\boriginally\b|\b(its|their|at the) former\b'
    '\bno longer\b(?! than)'
    '\bthe old (?!(arrays?|state|positions|velocities|values?|files?)\b)'
    '\b(one|the same) afternoon\b'
    '\binterleaved\b(?! (arrays?|data|layout|storage|channels?|samples)\b)'
    '\(was [^)]*\)'
    '\bas before\b(?! (the|a|an|it|its|each|every|any)\b)|\bdid before\b'
    '\bwas always\b|\bwent (down|up)\b'
    '\bwith the current (layout|settings|encoder|code|version)\b'
    '\bmeasured again\b|\bre-measured\b'
)
REGEX=$(IFS='|'; echo "${PATTERNS[*]}")

count=0
rev=""
while (($#)); do
    case "$1" in
        --count) count=1 ;;
        --rev) rev="${2:?--rev needs a commit}"; shift ;;
        -h|--help) sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
        *) echo "usage: $0 [--count] [--rev COMMIT]" >&2; exit 2 ;;
    esac
    shift
done

if [[ -n "$rev" ]]; then
    mapfile -t files < <(git ls-tree -r --name-only "$rev" -- README.md docs | grep -E '\.md$' | sort)
else
    mapfile -t files < <({ [[ -f README.md ]] && echo README.md; find docs -name '*.md' 2>/dev/null; } | sort)
fi

total=0
for file in "${files[@]}"; do
    if [[ -n "$rev" ]]; then
        text=$(git show "$rev:$file")
    else
        text=$(cat "$file")
    fi
    if ((count)); then
        n=$(grep -c -i -P -e "$REGEX" <<<"$text" || true)
        if ((n)); then
            printf '%4d  %s\n' "$n" "$file"
        fi
        total=$((total + n))
    else
        grep -n -i -P -e "$REGEX" <<<"$text" | sed "s|^|$file:|" || true
    fi
done
if ((count)); then
    printf '%4d  total\n' "$total"
fi
