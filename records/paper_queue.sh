#!/bin/bash
# The runs of records/paper still to do, as two lines of work, one per core:
#   bash records/paper_queue.sh a    and    bash records/paper_queue.sh b
# (from the repository root, after `mkdir -p runs/paper && cp -r records/paper/* runs/paper/`).
# Every command resumes its run folder where one exists; a finished run returns at once, so
# both lines can be started again after any interruption. A failing command stops its line.
#   bash records/paper_queue.sh snapshot
# keeps every run of runs/paper that is finished or has run half an hour in records/paper
# (scripts/snapshot_runs.py);
#   bash records/paper_queue.sh report ENGINE
# walks the records' new robots in the paper's engine (ENGINE: its folder, benchmarks/transfer.py
# --voxelyze), writes the page of the GA against MAP-Elites for the seeds both methods have
# started (its walking elites walked in the engine too), and regenerates docs/results.md from
# the records.
set -euo pipefail
cd "$(dirname "$0")/.."
resume() { if [ -f "$1/config.json" ]; then echo --resume; fi; }

evolve_3d() {  # NET SEED: a 3D run of the paper's settings
    local out=runs/paper/3d_$1/seed_$2
    mjregen evolve --dim 3 --net "$1" --preset 3d --pop 100 --gens 300 --truncation 20 \
        --elites 20 --sigma 0.1 --seed "$2" --backend serial --quiet --out "$out" $(resume "$out")
}

regen() {  # ROBOT NET SEED: Table 1 at the paper's regrowth scale
    local out=runs/paper/table1/$1_$2/seed_$3
    mjregen regen --paper "$1" --net "$2" --gens 1001 --seed "$3" --no-video --quiet \
        --out "$out" $(resume "$out")
}

grown() {  # ROBOT NET: Table 1 from the robot's grown CA state, where an NCA grows it exactly
    local from_seed=runs/paper/table1/$1_from_seed/seed_0
    mjregen regen --paper "$1" --damage seed --net "$2" --gens 1001 --seed 0 --no-video \
        --quiet --out "$from_seed" $(resume "$from_seed")
    if python -c "import sys; from mjregen.experiments import table1 as t
sys.exit(not t.grows_exactly(t.read_table1_run('$from_seed')))"; then
        local out=runs/paper/table1/$1_$2_grown/seed_0
        mjregen regen --checkpoint "$from_seed/regrowth.npz" --net "$2" --gens 1001 --seed 0 \
            --no-video --quiet --out "$out" $(resume "$out")
    else
        echo "$1: the NCA evolved to grow it from its seed does not grow it exactly" >&2
    fi
}

grow_regrow() {  # CUT SEED: one NCA that grows and regrows, judged by function; CUT paper
    # (the paper's fixed cut: grow_regrow_walk_ff) or half (each robot's own half:
    # grow_regrow_half_ff)
    local name=walk_ff cut=()
    if [ "$1" = half ]; then name=half_ff; cut=(--cut half); fi
    local out=runs/paper/grow_regrow_$name/seed_$2
    mjregen evolve --task grow-regrow "${cut[@]}" --regrown-weight 0.5 --cell-cost 0 --dim 3 \
        --net ff --preset 3d --seed "$2" --backend serial --quiet --out "$out" $(resume "$out")
}

KEEP_AFTER_S=1800  # an unfinished run is kept once its generations took this long
snapshot() {  # FOLDER RUN...: keep the runs among RUN... that are finished or have run
    # KEEP_AFTER_S in records/paper/FOLDER
    local into=$1
    shift
    if [ $# -gt 0 ]; then
        python scripts/snapshot_runs.py --into "records/paper$into" --keep-after "$KEEP_AFTER_S" "$@"
    fi
}

case "${1:-}" in
    a)
        for seed in 0 1 2 3 4 5 6 7; do evolve_3d ff "$seed"; done
        evolve_3d lstm 7
        for seed in 0 1 2; do regen biped ff "$seed"; regen tripod ff "$seed"; regen multiped lstm "$seed"; done
        regen biped lstm 0; regen tripod lstm 0; regen multiped ff 0
        grown multiped lstm
        ;;
    b)
        for seed in 0 1 2 3 4 5 6; do evolve_3d lstm "$seed"; done
        for seed in 0 1 2; do grow_regrow paper "$seed"; done
        for seed in 0 1; do grow_regrow half "$seed"; done
        # its GA runs are 3d_ff seeds 0-2 again (4.2, 4.6 and 1.9 h): about 20 h in all
        python scripts/qd_comparison.py --root runs/paper/qd --seeds 0 1 2 --pop 100 --gens 300 \
            --workers 1
        grown tripod ff; grow_regrow half 2  # here, so that both lines end about together
        ;;
    snapshot)
        shopt -s nullglob
        snapshot "" runs/paper/[23]d_*/seed_* runs/paper/grow_regrow_*/seed_*
        snapshot /table1 runs/paper/table1/*/seed_*
        snapshot /qd runs/paper/qd/*/seed_*
        ;;
    report)  # ENGINE: the paper engine's walks of the records' robots, then docs/results.md
        engine=${2:?usage: bash records/paper_queue.sh report ENGINE_FOLDER}
        python benchmarks/transfer.py --voxelyze "$engine" --each-run records/paper \
            --grow-regrow records/paper --table1 records/paper --json records/paper/transfer.json
        qd_seeds=$(for s in 0 1 2; do
            [ -d records/paper/qd/ga/seed_$s/evaluations ] &&
                [ -d records/paper/qd/map-elites/seed_$s/evaluations ] && echo "$s"
        done || true)
        if [ -n "$qd_seeds" ]; then  # the seeds both methods have started
            # shellcheck disable=SC2086  # one seed a word
            python scripts/qd_comparison.py --root records/paper/qd --seeds $qd_seeds \
                --pop 100 --gens 300 --report --docs docs/results --engine "$engine"
        fi
        python scripts/results_report.py --root records/paper
        ;;
    *)
        echo "usage: bash records/paper_queue.sh a|b|snapshot|report ENGINE" >&2
        exit 2
        ;;
esac
