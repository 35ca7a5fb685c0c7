#!/usr/bin/awk -f
# Exit 0 when, in a ctest LastTest.log, the output of the test named by -v test=NAME shows
# GoogleTest's "[  PASSED  ]", no "[  FAILED  ]", and LeakSanitizer's own fatal error (its
# tracer crashed at exit); exit 1 otherwise. Used by scripts/dev.sh sanitize.
function ends_with(s, t) { return length(s) >= length(t) && substr(s, length(s) - length(t) + 1) == t }
index($0, " Test: ") && ends_with($0, " Test: " test) { inside = 1; next }
inside && /<end of output>/ { inside = 0 }
inside && index($0, "[  PASSED  ]") { passed = 1 }
inside && index($0, "[  FAILED  ]") { failed = 1 }
inside && index($0, "LeakSanitizer has encountered a fatal error") { tracer = 1 }
END { exit !(passed && tracer && !failed) }
