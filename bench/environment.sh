# Sourced by the bench scripts: what a record's label names besides its numbers.
# environment_text EXE: the program (version and commit; its Kokkos backend) and the machine
# (CPU model, cores), on one line.
environment_text() {
  printf '%s; %s, %s cores' "$("$1" --version 2>/dev/null | head -n 2 | paste -sd ' ')" \
    "$(lscpu | sed -n 's/^Model name: *//p' | head -n 1)" "$(nproc)"
}
