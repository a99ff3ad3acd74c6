#!/usr/bin/env bash
# Two hosts on this machine for `lockstep mpi --hostfile`: two network
# namespaces joined by a veth pair, each with its own address, network stack
# and host name (a UTS namespace per process started there), a hostfile that
# names them by address, and an rsh agent for Open MPI's launcher that enters
# a host's namespace instead of ssh-ing to it. Traffic between the two stays
# inside this machine. Needs root (ip netns, unshare).
#
#   netns-hosts.sh run COMMAND...   make the hosts, run COMMAND with the
#                                   variables below set, tear everything down
#                                   (also when COMMAND fails, or on INT, TERM,
#                                   HUP) and exit with COMMAND's status; exit
#                                   77 with one line "SKIPPED: reason" where
#                                   namespaces cannot be made (CTest: skipped)
#   netns-hosts.sh on HOST COMMAND...  run COMMAND on HOST (its namespace, its name)
#   netns-hosts.sh agent HOST COMMAND  the rsh agent (OMPI_MCA_plm_rsh_agent):
#                                   COMMAND, one shell command line, on HOST
#
# For COMMAND: LOCKSTEP_HOSTS_A, LOCKSTEP_HOSTS_B (the hosts' names, also
# their namespaces'), LOCKSTEP_HOSTS_ADDRESS_A/_B, LOCKSTEP_HOSTS_LINK_B (B's
# end of the veth pair: `ip -n B link set LINK down` cuts B off),
# LOCKSTEP_HOSTS_NETWORK (the CIDR, for lockstep mpi --network),
# LOCKSTEP_HOSTS_HOSTFILE (both addresses, 2 slots each),
# LOCKSTEP_HOSTS_SCRIPT (this script), OMPI_MCA_plm_rsh_agent and the two
# OMPI_ALLOW_RUN_AS_ROOT variables. mpirun is started on host A (`on A`):
# Open MPI takes A's address in the hostfile for its own host and starts the
# ranks there itself, and B's through the agent.
set -uo pipefail

script=$(readlink -f "$0")

skip() {
  echo "SKIPPED: two hosts as network namespaces cannot be made here: $*"
  exit 77
}

# The host's namespace: its name is the namespace's.
on() {
  local host=$1
  shift
  exec ip netns exec "$host" unshare --uts sh -c 'hostname "$0" && exec "$@"' "$host" "$@"
}

agent() {
  local host=$1
  shift
  local map=${LOCKSTEP_HOSTS_DIR:?the agent runs under netns-hosts.sh run}/hosts.map
  local namespace
  namespace=$(awk -v host="$host" '$1 == host || $2 == host { print $2 }' "$map")
  if [ -z "$namespace" ]; then
    echo "netns-hosts.sh agent: no host $host in $map" >&2
    exit 255
  fi
  # Open MPI hands the remote command as words for a shell, as ssh would.
  on "$namespace" sh -c "$*"
}

teardown() {
  local namespace pids
  for namespace in "${namespaces[@]}"; do
    pids=$(ip netns pids "$namespace" 2>/dev/null)
    # shellcheck disable=SC2086  # one pid a word
    [ -n "$pids" ] && kill -KILL $pids 2>/dev/null
    ip netns del "$namespace" 2>/dev/null
  done
  namespaces=()
  [ -n "${dir:-}" ] && rm -rf "$dir"
  dir=
}

run() {
  [ "$#" -ge 1 ] || { echo "usage: netns-hosts.sh run COMMAND..." >&2; exit 2; }
  [ "$(id -u)" = 0 ] || skip "not root"
  command -v ip >/dev/null || skip "no ip command (iproute2)"
  command -v unshare >/dev/null || skip "no unshare command (util-linux)"
  local tag=$$
  local a=lsa$tag b=lsb$tag
  # A /24 of 10.231.0.0/16 that no interface here has.
  local third=$((tag % 250 + 1))
  while ip -o -4 addr show | grep -q " 10\.231\.$third\."; do third=$((third % 250 + 1)); done
  local network=10.231.$third.0/24 address_a=10.231.$third.1 address_b=10.231.$third.2

  # Hosts a run killed outright left behind (SIGKILL runs no trap): their
  # run's pid is gone.
  local stale
  for stale in $(ip netns list 2>/dev/null | awk '$1 ~ /^ls[ab][0-9]+$/ { print $1 }'); do
    kill -0 "${stale#ls?}" 2>/dev/null && continue
    namespaces=("$stale")
    teardown
  done

  namespaces=()
  child=
  dir=$(mktemp -d /tmp/lockstep-netns-hosts-XXXXXX)
  trap teardown EXIT
  trap '[ -n "$child" ] && kill -TERM "$child" 2>/dev/null; teardown; exit 130' INT
  trap '[ -n "$child" ] && kill -TERM "$child" 2>/dev/null; teardown; exit 143' TERM
  trap '[ -n "$child" ] && kill -TERM "$child" 2>/dev/null; teardown; exit 129' HUP
  local error
  error=$(ip netns add "$a" 2>&1) || skip "ip netns add: $error"
  namespaces+=("$a")
  error=$(ip netns add "$b" 2>&1) || skip "ip netns add: $error"
  namespaces+=("$b")
  error=$( {
    ip link add "$a" type veth peer name "$b" &&
      ip link set "$a" netns "$a" && ip link set "$b" netns "$b" &&
      ip -n "$a" addr add "$address_a/24" dev "$a" && ip -n "$b" addr add "$address_b/24" dev "$b" &&
      ip -n "$a" link set lo up && ip -n "$b" link set lo up &&
      ip -n "$a" link set "$a" up && ip -n "$b" link set "$b" up
  } 2>&1) || skip "veth pair: $error"
  error=$(ip netns exec "$a" unshare --uts true 2>&1) || skip "unshare --uts: $error"

  printf '%s %s\n%s %s\n' "$address_a" "$a" "$address_b" "$b" >"$dir/hosts.map"
  printf '%s slots=2\n%s slots=2\n' "$address_a" "$address_b" >"$dir/hostfile"
  echo "netns-hosts.sh: hosts $a ($address_a) and $b ($address_b), veth $a-$b, network $network" >&2

  LOCKSTEP_HOSTS_DIR=$dir LOCKSTEP_HOSTS_A=$a LOCKSTEP_HOSTS_B=$b \
    LOCKSTEP_HOSTS_ADDRESS_A=$address_a LOCKSTEP_HOSTS_ADDRESS_B=$address_b LOCKSTEP_HOSTS_LINK_B=$b \
    LOCKSTEP_HOSTS_NETWORK=$network LOCKSTEP_HOSTS_HOSTFILE=$dir/hostfile LOCKSTEP_HOSTS_SCRIPT=$script \
    OMPI_MCA_plm_rsh_agent="$script agent" OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 \
    "$@" &
  child=$!
  # wait returns early when a trapped signal arrives; the trap then tears down.
  wait "$child"
  local status=$?
  teardown
  trap - EXIT INT TERM HUP
  return "$status"
}

case "${1:-}" in
  run) shift; run "$@"; exit $? ;;
  on) shift; on "$@" ;;
  agent) shift; agent "$@" ;;
  *) echo "usage: netns-hosts.sh run COMMAND... | on HOST COMMAND... | agent HOST COMMAND" >&2; exit 2 ;;
esac
