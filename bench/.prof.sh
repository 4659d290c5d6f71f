. bench/nvidia_env.sh >/dev/null 2>&1
cd /tmp/corvid/b/bin
./vk_timings 2>&1 | tail -2
for g in 1 2 4; do ./corvid-render --adapters NVIDIA --size 1920x1080 --gpus $g --frames 16 --trace $OUT/trace$g.json --stats $OUT/stats$g.json --out /tmp/f > $OUT/log$g.txt 2>&1; done
for g in 2; do ./corvid-render --adapters NVIDIA --size 1920x1080 --gpus $g --frames 16 --reflections off --trace $OUT/trace${g}r.json --out /tmp/f > $OUT/log${g}r.txt 2>&1; done
./corvid-render --adapters NVIDIA --size 1920x1080 --gpus 1 --frames 16 --reflections off --trace $OUT/trace1r.json --out /tmp/f > $OUT/log1r.txt 2>&1
