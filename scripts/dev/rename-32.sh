#!/usr/bin/env bash
# Issue 32's renames, as a script so that they can be re-run on a tree that has gained files since
# (it works on every file git knows or would add, found by grep, not on a fixed list). Idempotent:
# a second run changes nothing. Run from anywhere inside the repository; then build and test.
#   1. sampling/ moves from namespace lensim::render to lensim::sampling. The names it declares
#      (read from its headers) are requalified where code wrote render::NAME, and files that use
#      them unqualified, in namespace lensim::render or after `using namespace lensim::render;`,
#      get `using namespace lensim::sampling;` after that line.
#   2. scene/builder.h, which holds the scene description (the data model the parser fills), is
#      renamed scene/description.h (scene/builder.cpp, the builder, keeps its name); includes and
#      mentions are updated.
#   3. ExitPupilSampler::area_mm2() becomes areaMm2(), as the other unit-suffixed functions are
#      spelled (centreAreaMm2()); data members named area_mm2 keep their names.
#   4. Files named for what they hold: camera/autofocus.{h,cpp} (zone files, the sharpness score
#      and the search over film distances that the scene-level render/autofocus_scene drives)
#      becomes camera/focus_search; scene/film_sensor.{h,cpp} (the sensor names a scene may give,
#      the imaging ratio and the white-balance temperature; the sensors themselves are
#      render/film/pixel_sensor) becomes scene/sensor_settings. Includes, CMake lists and
#      mentions are updated.
#   5. render/ builds one library, lensim_render: lensim_engine in CMake files becomes
#      lensim_render (render/CMakeLists.txt itself is edited by hand).
# Usage: scripts/dev/rename-32.sh [--dry-run]   (--dry-run: list the files it would change)
set -euo pipefail
cd "$(git rev-parse --show-toplevel)"
dry=0
[ "${1:-}" = "--dry-run" ] && dry=1

# Every text file git tracks or would add (untracked, not ignored), outside shared data.
code_files() { git ls-files -co --exclude-standard -- '*.h' '*.hpp' '*.cpp' '*.cc' '*.in'; }
text_files() {
  git ls-files -co --exclude-standard -- '*.h' '*.hpp' '*.cpp' '*.cc' '*.in' '*.md' '*.txt' \
    '*.cmake' '*.py' '*.sh' 'scripts/*' 'bench/*' 'tools/*' | grep -v '^scripts/dev/rename-32.sh$' |
    while read -r f; do [ -f "$f" ] && grep -Iq . "$f" && echo "$f"; done
}
changed=()
# apply FILE PERL-EXPRESSION: edits FILE in place (the whole file as one string) when the
# expression changes it.
tmp=$(mktemp)
trap 'rm -f "$tmp"' EXIT
apply() {
  perl -0777 -pe "$2" "$1" > "$tmp"
  if ! cmp -s "$tmp" "$1"; then
    changed+=("$1")
    [ $dry = 1 ] || cat "$tmp" > "$1"
  fi
}

# --- 1. namespace lensim::sampling ---------------------------------------------------------------
sdir=src/lensim/sampling
for f in $(git ls-files -co --exclude-standard -- "$sdir/*.h" "$sdir/*.cpp"); do
  apply "$f" 's/\bnamespace lensim::render\b/namespace lensim::sampling/g'
done
# The names sampling/'s headers declare at namespace scope (their style: no indentation there):
# classes, structs, enums, aliases, constants and functions.
names=$(cat "$sdir"/*.h | perl -ne '
  print "$1\n" if /^(?:class|struct|enum class|enum)\s+(\w+)/;
  print "$1\n" if /^using\s+(\w+)\s*=/;
  print "$1\n" if /^(?:inline\s+)?constexpr\s+[^=(]*?\b(\w+)\s*=/;
  print "$1\n" if /^(?!(?:return|namespace|using|template|class|struct|enum)\b)[A-Za-z_][\w:<>,*& ]*?[\s*&](\w+)\(/;
' | sort -u)
[ -n "$names" ] || { echo "rename-32: no names found in $sdir/*.h" >&2; exit 1; }
alt=$(echo "$names" | paste -sd'|')
export RENAME32_NAMES="$alt"
# beyond_sampling FILE: whether FILE, or a local header it includes (followed recursively),
# includes a lensim header other than sampling/'s and util/'s.
beyond_sampling() {
  perl -e '
    my %seen;
    sub walk {
      my ($f) = @_;
      return 0 if $seen{$f}++;
      open(my $h, "<", $f) or return 0;
      my $dir = $f =~ m{^(.*)/} ? $1 : ".";
      while (<$h>) {
        next unless /^#include "([^"]+)"/;
        my $i = $1;
        if ($i =~ m{^lensim/}) { return 1 unless $i =~ m{^lensim/(sampling|util)/}; next }
        return 1 if walk("$dir/$i");
      }
      return 0;
    }
    exit(walk($ARGV[0]) ? 0 : 1)' "$1"
}
forward_decls=$(cat <<'PERL'
my $names = $ENV{RENAME32_NAMES};
s!^(namespace lensim::render(?:::\w+)? \{\n)(.*?)^\}!
  my ($open, $body) = ($1, $2);
  my @moved = $body =~ /^((?:class|struct) (?:$names);\n)/mg;
  $body =~ s/^(?:class|struct) (?:$names);\n//mg;
  my $block = @moved ? "namespace lensim::sampling {\n" . join("", @moved) . "}\n" : "";
  $block . ($body =~ /\S/ ? ($block ? "\n" : "") . $open . $body . "}" : "__DROP__")
!gmse;
s{__DROP__\n}{}g;
PERL
)
for f in $(code_files | grep -v "^$sdir/"); do
  # render::NAME (or lensim::render::NAME) -> sampling::NAME
  apply "$f" "s/\\b((?:lensim::)?)render::($alt)\\b/\${1}sampling::\$2/g"
  # Forward declarations of its classes inside a namespace lensim::render block move to a
  # namespace lensim::sampling block before it (the render block is dropped if left empty).
  apply "$f" "$forward_decls"
  # A file that says `using namespace lensim::render;` but includes only headers of sampling/
  # and util/ (which no longer declare that namespace), itself or through local headers, means
  # sampling.
  if grep -q '^using namespace lensim::render;' "$f" && ! beyond_sampling "$f"; then
    apply "$f" 's/^using namespace lensim::render;\n(using namespace lensim::sampling;\n)?/using namespace lensim::sampling;\n/m'
  fi
  # Files in namespace lensim::render (or one inside it), or with `using namespace
  # lensim::render;`, that use a name unqualified (comments and strings aside) which they do not
  # declare themselves.
  grep -q '^using namespace lensim::sampling;' "$f" && continue
  perl -0777 -ne "s{//[^\n]*}{}g; s{/\\*.*?\\*/}{}gs; s{\"(?:[^\"\\\\\n]|\\\\.)*\"}{}g;
                  my %own = map { \$_ => 1 } /\\b(?:class|struct|enum|using|double|int|float|auto)\\s+(\\w+)\\s*[={:]/g;
                  my @used = grep { !\$own{\$_} } /(?<![\\w:.>])($alt)\\b/g;
                  exit(!@used)" "$f" || continue
  if grep -qE '^namespace lensim::render(::\w+)? \{' "$f"; then
    apply "$f" 's/^(namespace lensim::render(?:::\w+)? \{\n)/$1\nusing namespace lensim::sampling;\n/m'
  elif grep -q '^using namespace lensim::render;' "$f"; then
    apply "$f" 's/^(using namespace lensim::render;\n)/$1using namespace lensim::sampling;\n/m'
  fi
done

# --- 2. scene/builder.h -> scene/description.h ---------------------------------------------------
if [ -f src/lensim/scene/builder.h ]; then
  changed+=(src/lensim/scene/builder.h)
  [ $dry = 1 ] || git mv src/lensim/scene/builder.h src/lensim/scene/description.h
fi
for f in $(text_files); do
  apply "$f" 's{\bscene/builder\.h\b}{scene/description.h}g'
done

# --- 3. area_mm2() -> areaMm2() ------------------------------------------------------------------
for f in $(code_files); do
  apply "$f" 's/(ExitPupilSampler::|\.|->)area_mm2\(/$1areaMm2(/g; s/(\bdouble )area_mm2(\(Vec2 film_mm)/$1areaMm2$2/g'
done

# --- 4. camera/focus_search, scene/sensor_settings ----------------------------------------------
for pair in camera/autofocus:camera/focus_search scene/film_sensor:scene/sensor_settings; do
  from=${pair%%:*} to=${pair#*:}
  for ext in h cpp; do
    if [ -f "src/lensim/$from.$ext" ]; then
      changed+=("src/lensim/$from.$ext")
      [ $dry = 1 ] || git mv "src/lensim/$from.$ext" "src/lensim/$to.$ext"
    fi
  done
done
for f in $(text_files); do
  apply "$f" 's{\bcamera/autofocus\.(h|cpp)\b}{camera/focus_search.$1}g;
              s{\bscene/film_sensor\.(h|cpp)\b}{scene/sensor_settings.$1}g;
              s{\bfilm_sensor\.(h|cpp)\b}{sensor_settings.$1}g'
done
for f in src/lensim/camera/CMakeLists.txt src/lensim/scene/CMakeLists.txt; do
  apply "$f" 's{^(\s+)autofocus\.cpp$}{$1focus_search.cpp}m; s{^(\s+)film_sensor\.cpp$}{$1sensor_settings.cpp}m'
done

# --- 5. one library for render/ ---------------------------------------------------------------
for f in $(git ls-files -co --exclude-standard -- 'CMakeLists.txt' '*/CMakeLists.txt' '*.cmake'); do
  [ "$f" = src/lensim/render/CMakeLists.txt ] && continue
  apply "$f" 's/\blensim_engine\b/lensim_render/g'
done

[ ${#changed[@]} = 0 ] || printf '%s\n' "${changed[@]}" | sort -u | sed "s/^/rename-32: $([ $dry = 1 ] && echo would change || echo changed) /"
echo "rename-32: ${#changed[@]} edits"
