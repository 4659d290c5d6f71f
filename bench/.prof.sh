. bench/nvidia_env.sh >/dev/null 2>&1
cd /tmp/corvid/b/bin
r() { local tag=$1; shift; /usr/bin/time -f "$tag cpu user %U sys %S wall %e" ./corvid-render --adapters NVIDIA --size 1920x1080 "$@" --out /tmp/f > /tmp/r.log 2>/tmp/t.log; echo "$tag: $(grep -o '[0-9.]* ms per frame' /tmp/r.log) $(grep -o 'transfers between devices.*' /tmp/r.log) | $(tail -1 /tmp/t.log)"; }
for g in 1 2 4; do r "g$g" --gpus $g --frames 64; done
for g in 1 2 4; do r "g$g refl-off" --gpus $g --frames 64 --reflections off; done
CORVID_TRANSFER_PATH=device r "g2 device" --gpus 2 --frames 64
CORVID_VGPU_DEVICE=separate r "g2 separate" --gpus 2 --frames 64
for g in 1 2; do ./corvid-render --adapters NVIDIA --size 1920x1080 --gpus $g --frames 16 --trace $OUT/trace$g.json --stats $OUT/stats$g.json --out /tmp/f > $OUT/log$g.txt 2>&1; done
nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv
