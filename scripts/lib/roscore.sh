# shellcheck shell=bash
# start_roscore LOG: a master of its own, on a free port, answering before it returns (sourced by the scripts
# and the install test; needs nothing but bash and the ROS Python modules).
# Exports ROS_MASTER_URI and ROSCORE_PID. Why not a fixed port and a fixed wait: on a loaded 2-core machine a
# roscore has taken longer than 20 s to answer, and a port drawn at random can be one another test's master or
# node already holds (roscore then exits at once). So the port is one the kernel just handed out, a master that
# exits is started again on another, and a master that never answers fails with its log instead of letting the
# next command say "Unable to communicate with master!".
start_roscore() {
  local log=$1 attempt port started
  for attempt in 1 2 3; do
    port=$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("localhost", 0)); print(s.getsockname()[1])')
    export ROS_MASTER_URI="http://localhost:$port"
    roscore -p "$port" >"$log" 2>&1 &
    ROSCORE_PID=$!
    started=$SECONDS
    while [ $((SECONDS - started)) -lt 120 ]; do
      rosparam get /run_id >/dev/null 2>&1 && return 0
      kill -0 "$ROSCORE_PID" 2>/dev/null || break
      sleep 0.5
    done
    if kill -0 "$ROSCORE_PID" 2>/dev/null; then
      kill "$ROSCORE_PID"
      echo "roscore on port $port did not answer within $((SECONDS - started)) s; its log:" >&2
      tail -n 20 "$log" >&2
      return 1
    fi
    echo "roscore on port $port exited (attempt $attempt); its log:" >&2
    tail -n 5 "$log" >&2
  done
  return 1
}
