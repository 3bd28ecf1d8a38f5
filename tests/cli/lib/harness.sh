# Sourced by tests/cli/*.sh (this folder is not globbed as tests). The caller sets
# imsynth and root (its arguments) first; this gives it a scratch directory $tmp removed on
# exit, a failure count, and the checks below. Each check prints "ok: ..." or "FAIL: ...";
# the script ends with `finish`.
set -u
# The Python of the checks, chosen once: Debian's (numpy is there) when present, else the
# first on PATH. Never "the one, else the other": a failed check rerun by the second from a
# heredoc reads an empty stdin and passes (every heredoc check did so until session 27).
if [ -x /usr/bin/python3 ]; then python=/usr/bin/python3; else python=python3; fi
py() { "$python" "$@"; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
failures=0
check() { # description, expected exit code, actual exit code
    if [ "$2" != "$3" ]; then
        echo "FAIL: $1: exit $3, expected $2"; failures=$((failures + 1))
    else
        echo "ok: $1"
    fi
}
expect_stderr() { # description, fragment (stderr saved in $tmp/err)
    if grep -q -- "$2" "$tmp/err"; then echo "ok: $1"; else
        echo "FAIL: $1: stderr lacks \"$2\":"; cat "$tmp/err"; failures=$((failures + 1)); fi
}
expect_stdout() { # description, fragment (stdout saved in $tmp/out)
    if grep -q -- "$2" "$tmp/out"; then echo "ok: $1"; else
        echo "FAIL: $1: stdout lacks \"$2\":"; cat "$tmp/out"; failures=$((failures + 1)); fi
}
dataset_digest() { # dataset: the content digest `imsynth dataset info --digest` prints
    "$imsynth" dataset info "$1" --digest | sed -n 's/.*content digest *//p'
}
finish() {
    [ "$failures" = 0 ] || { echo "$failures failure(s)"; exit 1; }
    echo "all ok"
}
