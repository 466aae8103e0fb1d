cd /work/wt/warmdual && . /work/main/.venv/bin/activate && export PYTHONPATH=/work/wt/warmdual OMP_NUM_THREADS=1
for dual in 0 1; do
  rm -rf /tmp/wd/y8_$dual; echo "y8 dual=$dual start $(uptime)"
  STLC_DUAL_WARM=$dual nice -n 10 stlc sweep specs/handover.stl --mission handover_left_tb --vary 'operator.pos.y=-0.15 m:0.15 m:8' -o /tmp/wd/y8_$dual -q; echo "rc $? end $(uptime)"
done
for dual in 0 1; do
  rm -rf /tmp/wd/r12_$dual; echo "r12 dual=$dual start $(uptime)"
  STLC_DUAL_WARM=$dual nice -n 10 stlc sweep specs/handover.stl --mission handover_left_tb --vary 'uav1.start.pos.y=-0.3 m:0.3 m:2' --vary 'operator.att.z=-20 deg:20 deg:2' --random 12 --seed 3 -o /tmp/wd/r12_$dual -q; echo "rc $? end $(uptime)"
done
