# Bash completion for blmd-ident, blmd-sim, blmd-surface, blmd-tune, blmd-design, blmd-export and
# blmd-track (docs/cli.md, "Completion"). One file for the commands; `cmake --install` puts a copy under each command's name
# in share/bash-completion/completions, where bash-completion loads it on first use. Without
# an install: source completions/blmd.bash. Needs bash only (not the bash-completion
# package's helpers).
#
# Completes the flags of each command, file names after the flags that name files (configs:
# *.json and folders), the optimisers after --method, the effects after --effect and
# --candidates (a comma list), the models after --init-config, the trace columns after
# --observe, --noise and --derive, the choices of --error, --initial-state, --delimiter and
# --duplicate-time, and blmd-surface's subcommands merge and plot; blmd-tune's --loop
# choices and its --limit names (u=, i=); blmd-design's --family and its --limit columns.
#
# The lists below are the commands' own: tests/completion_test.cc compares them with the
# flags of each command's --help and with the model, effect and optimiser registries, so they
# cannot drift apart.

_blmd_models="blmd dc_servo rigid_load"
_blmd_methods="ceres classic fsd powell"
_blmd_effects="asymmetric_viscous cogging coulomb_friction current_offset dead_time gravity load_torque quadratic_drag spring stribeck two_mass"
_blmd_columns="i ib ic theta u w"

_blmd_ident_flags="--baseline --baseline-dir --batch --bic-margin --candidates --closed-loop --column --config --decimate --delimiter --derive --discover --drift-alpha --duplicate-time --error --export-matlab --fail-above-nrmse --fail-on-warning --filter-hz --free --help --html --init-config --initial --initial-state --json --max-effects --max-evaluations --method --min-share --names --new-baselines --no-header --no-progress --noise-std --observe --option --out --progress --quiet --report --resample --sample-rate --scale --seed --select --simulate-from --split --threads --trace --validate --verbose --version --weighting --write-config"
_blmd_sim_flags="--config --delimiter --duplicate-time --effect --help --init-config --input --names --no-header --noise --out --quiet --sample-rate --seed --version"
_blmd_surface_flags="--closed-loop --column --config --decimate --delimiter --derive --duplicate-time --error --filter-hz --force --grid --help --initial-state --json --names --no-header --observe --out --quiet --resample --sample-rate --scale --select --shard --simulate-from --split --svg --threads --trace --version"
_blmd_tune_flags="--config --crossover --current-bandwidth --delay --duration --fail-on-warning --filter-ratio --from-report --help --integral-ratio --json --limit --loop --notch --phase-margin --position-crossover --quiet --report --sample-rate --step --threads --version --write-config"
_blmd_design_flags="--column --config --delimiter --derive --duplicate-time --duration --fail-on-warning --family --from-report --help --initial-state --json --limit --names --no-header --noise --quiet --report --resample --sample-rate --scale --select --split --target --threads --trace --version --write-config --write-input"
_blmd_export_flags="--change-margin --cogging-points --config --filter-hz --format --from-report --gate --help --memory --out --quiet --speed-noise --tracker-rate --version"
_blmd_track_flags="--change-margin --column --config --delimiter --derive --duplicate-time --fail-on-change --filter-hz --from-report --gate --help --html --initial-state --memory --names --no-header --out --quiet --report --resample --sample-rate --scale --select --speed-noise --split --trace --version"
_blmd_surface_merge_flags="--help --out"
_blmd_surface_plot_flags="--help --quiet --svg --title"

# COMPREPLY = the words of $1 that start with $2.
_blmd_words() {
  mapfile -t COMPREPLY < <(compgen -W "$1" -- "$2")
}

# COMPREPLY = files and folders that start with $1; with $2 (a glob such as *.json) only the
# files that match it, and every folder.
_blmd_files() {
  compopt -o filenames 2>/dev/null
  if [[ -n $2 ]]; then
    mapfile -t COMPREPLY < <(compgen -f -X "!$2" -- "$1"; compgen -d -- "$1")
  else
    mapfile -t COMPREPLY < <(compgen -f -- "$1")
  fi
}

# COMPREPLY for a comma list (--candidates, --observe): the words of $1 that start with the
# part of $2 after its last comma, each after the part before it; names already in the list
# are left out.
_blmd_list() {
  local head="" tail=$2 word
  if [[ $2 == *,* ]]; then
    head=${2%,*},
    tail=${2##*,}
  fi
  COMPREPLY=()
  for word in $1; do
    [[ $word == "$tail"* && ,$head != *,"$word",* ]] && COMPREPLY+=("$head$word")
  done
}

# COMPREPLY = NAME$3 for the words NAME of $1 that start with $2 (--effect NAME:, --noise
# NAME=): the value follows without a space.
_blmd_prefixes() {
  local word
  COMPREPLY=()
  for word in $1; do
    [[ $word == "$2"* ]] && COMPREPLY+=("$word$3")
  done
  compopt -o nospace 2>/dev/null
}

# Completes the word COMP_CWORD of COMP_WORDS for command $1 (ident, sim, surface or tune).
_blmd_complete() {
  local command=$1 cur=${COMP_WORDS[COMP_CWORD]} prev=""
  ((COMP_CWORD > 0)) && prev=${COMP_WORDS[COMP_CWORD - 1]}
  # --flag=value: readline splits it at '=' (COMP_WORDBREAKS) into --flag, =, value.
  if [[ $cur == "=" ]]; then
    cur=""
  elif [[ $prev == "=" ]] && ((COMP_CWORD > 1)); then
    prev=${COMP_WORDS[COMP_CWORD - 2]}
  fi
  # A value given in one word, --flag=value, when '=' does not break words.
  if [[ $cur == --*=* ]]; then
    prev=${cur%%=*}
    cur=${cur#*=}
  fi
  local flags subcommand="" k
  case $command in
    ident) flags=$_blmd_ident_flags ;;
    sim) flags=$_blmd_sim_flags ;;
    tune) flags=$_blmd_tune_flags ;;
    design) flags=$_blmd_design_flags ;;
    export) flags=$_blmd_export_flags ;;
    track) flags=$_blmd_track_flags ;;
    surface)
      flags=$_blmd_surface_flags
      for ((k = 1; k < COMP_CWORD; ++k)); do
        case ${COMP_WORDS[k]} in
          merge | plot)
            subcommand=${COMP_WORDS[k]}
            break
            ;;
        esac
      done
      [[ $subcommand == merge ]] && flags=$_blmd_surface_merge_flags
      [[ $subcommand == plot ]] && flags=$_blmd_surface_plot_flags
      ;;
  esac

  local value=1 # whether $prev takes the value being completed
  case $prev in
    --config | --report | --baseline | --write-config | --from-report) _blmd_files "$cur" '*.json' ;;
    --export-matlab) _blmd_files "$cur" '*.m' ;;
    --trace | --validate | --input | --out | --html | --svg | --write-input | --baseline-dir) _blmd_files "$cur" ;;
    --batch) _blmd_files "$cur" '*.csv' ;;
    --method) _blmd_words "$_blmd_methods" "$cur" ;;
    --init-config) _blmd_words "$_blmd_models" "$cur" ;;
    --candidates) _blmd_list "$_blmd_effects" "$cur" ;;
    --observe) _blmd_list "$_blmd_columns" "$cur" ;;
    --effect) _blmd_prefixes "$_blmd_effects" "$cur" ":" ;;
    --noise) _blmd_prefixes "$_blmd_columns" "$cur" "=" ;;
    --limit)
      # blmd-tune limits the drive (u=, i=); blmd-design the input and the outputs.
      if [[ $command == tune ]]; then
        _blmd_prefixes "i u" "$cur" "="
      else
        _blmd_prefixes "$_blmd_columns" "$cur" "="
      fi
      ;;
    --family) _blmd_words "all chirp prbs square steps" "$cur" ;;
    --derive) _blmd_words "w=theta" "$cur" ;;
    --error) _blmd_words "output equation" "$cur" ;;
    --simulate-from) _blmd_words "command reference" "$cur" ;;
    --weighting) _blmd_words "noise variance" "$cur" ;;
    --initial-state) _blmd_words "config trace" "$cur" ;;
    --delimiter) _blmd_words ", ; tab" "$cur" ;;
    --duplicate-time) _blmd_words "error first mean" "$cur" ;;
    --resample) _blmd_words "auto" "$cur" ;; # or a step in seconds
    --loop) _blmd_words "position speed" "$cur" ;;
    --notch) _blmd_words "auto off" "$cur" ;;
    --format) _blmd_words "c mujoco odrive" "$cur" ;;
    --bic-margin | --min-share | --column | --decimate | --target | --fail-above-nrmse | --filter-hz | --free | \
      --grid | --initial | --max-effects | --max-evaluations | --option | --scale | --seed | --noise-std | \
      --select | --shard | --split | --threads | --title | --crossover | --phase-margin | \
      --step | --duration | --integral-ratio | --filter-ratio | --sample-rate | --delay | \
      --current-bandwidth | --position-crossover | --drift-alpha | --names | --cogging-points | \
      --tracker-rate | --memory | --gate | --change-margin | --speed-noise)
      COMPREPLY=() # a value of the user's own
      ;;
    *) value=0 ;;
  esac
  ((value)) && return

  if [[ $cur == -* ]]; then
    _blmd_words "$flags" "$cur"
  elif [[ $command == surface && -z $subcommand ]] && ((COMP_CWORD == 1)); then
    _blmd_words "merge plot $flags" "$cur"
  elif [[ -n $subcommand ]]; then
    _blmd_files "$cur" '*.csv' # merge's parts, plot's surface
  else
    _blmd_words "$flags" "$cur"
  fi
}

_blmd_ident() { _blmd_complete ident; }
_blmd_sim() { _blmd_complete sim; }
_blmd_surface() { _blmd_complete surface; }
_blmd_tune() { _blmd_complete tune; }
_blmd_design() { _blmd_complete design; }
_blmd_export() { _blmd_complete export; }
_blmd_track() { _blmd_complete track; }

complete -F _blmd_ident blmd-ident
complete -F _blmd_sim blmd-sim
complete -F _blmd_surface blmd-surface
complete -F _blmd_tune blmd-tune
complete -F _blmd_design blmd-design
complete -F _blmd_export blmd-export
complete -F _blmd_track blmd-track
