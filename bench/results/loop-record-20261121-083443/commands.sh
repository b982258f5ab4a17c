R=bench/results/loop-record-20261121-083443
# run from the repository root; each writes <tag>.json (one line) and <tag>.log
bash bench/run_loop_record.sh $R lz4 --experiments 8 --evaluation 4 --goals 1 --record
bash bench/run_loop_record.sh $R lz4-images --experiments 8 --evaluation 4 --goals 1 --record-images
bash bench/run_loop_record.sh $R none --experiments 8 --evaluation 4 --goals 1 --record --record-compression none
