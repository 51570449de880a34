"""The paper's baseline: a genetic algorithm with task logic.

Chromosome = a task order (permutation) + a robot split (n_robots − 1 sorted cut points): robot
r does the r-th segment of the order. Fitness = the nominal makespan of the decoded schedule
under the environment's step rules (plan.decode_task_lists, which keeps every schedule in
order and complete). Tournament selection, order crossover (OX), swap/inversion/move/cut
mutations, elitism, and a final iterated local search from the best chromosome (hill-climbs over
single task moves and swaps, restarted from random kicks of the best), all within
`max_evaluations` decoded chromosomes (a count, not a time, so the plan does not depend on the
machine). Seeded: the same seed gives the same plan.
"""
from __future__ import annotations

import math
import random
from typing import Dict, List, Tuple

from marl_mrta.baselines.plan import Plan, SchedulingInstance, decode_task_lists, plan_from_run
from marl_mrta.baselines.settings import GaSettings

Chromosome = Tuple[Tuple[int, ...], Tuple[int, ...]]   # (order, cuts)


def split(order: Tuple[int, ...], cuts: Tuple[int, ...]) -> List[List[int]]:
    bounds = (0,) + cuts + (len(order),)
    return [list(order[bounds[r]:bounds[r + 1]]) for r in range(len(bounds) - 1)]


def _order_crossover(rng: random.Random, a: Tuple[int, ...], b: Tuple[int, ...]) -> Tuple[int, ...]:
    n = len(a)
    i, j = sorted(rng.sample(range(n + 1), 2))
    middle = a[i:j]
    rest = [g for g in b if g not in middle]
    return tuple(rest[:i]) + middle + tuple(rest[i:])


def join(lists: List[List[int]]) -> Chromosome:
    """Inverse of split: the task order and the cut points of per-robot lists."""
    order: List[int] = []
    cuts: List[int] = []
    for tasks in lists:
        order += tasks
        cuts.append(len(order))
    return tuple(order), tuple(cuts[:-1])


def _mutate(rng: random.Random, order: Tuple[int, ...], cuts: Tuple[int, ...], n_tasks: int) -> Chromosome:
    """One of: swap two tasks, reverse a section, move one task to any place of any robot's
    list, shift a cut point."""
    kind = rng.randrange(4) if cuts else rng.randrange(3)
    if kind == 2:
        lists = split(order, cuts)
        source = rng.choice([r for r, tasks in enumerate(lists) if tasks])
        task = lists[source].pop(rng.randrange(len(lists[source])))
        target = rng.randrange(len(lists))
        lists[target].insert(rng.randint(0, len(lists[target])), task)
        return join(lists)
    genes = list(order)
    if kind == 0 and n_tasks > 1:
        i, j = rng.sample(range(n_tasks), 2)
        genes[i], genes[j] = genes[j], genes[i]
    elif kind == 1:
        i, j = sorted(rng.sample(range(n_tasks + 1), 2))
        genes[i:j] = reversed(genes[i:j])
    elif kind == 3:
        moved = list(cuts)
        k = rng.randrange(len(moved))
        moved[k] = min(max(moved[k] + rng.choice((-2, -1, 1, 2)), 0), n_tasks)
        cuts = tuple(sorted(moved))
    return tuple(genes), cuts


def _neighbours(chrom: Chromosome):
    """Every single move of a task (to any place of any robot's list), every swap of two tasks,
    and every exchange of two robots' list ends (which no single move or swap reaches: two
    robots that would trade their last stages)."""
    lists = split(*chrom)
    for source, tasks in enumerate(lists):
        for i in range(len(tasks)):
            for target in range(len(lists)):
                for k in range(len(lists[target]) + (0 if target == source else 1)):
                    moved = [list(t) for t in lists]
                    task = moved[source].pop(i)
                    moved[target].insert(k, task)
                    yield join(moved)
    order, cuts = chrom
    for i in range(len(order)):
        for j in range(i + 1, len(order)):
            genes = list(order)
            genes[i], genes[j] = genes[j], genes[i]
            yield tuple(genes), cuts
    for a in range(len(lists)):
        for b in range(a + 1, len(lists)):
            for i in range(len(lists[a]) + 1):
                for k in range(len(lists[b]) + 1):
                    if i == len(lists[a]) and k == len(lists[b]):
                        continue
                    exchanged = [list(t) for t in lists]
                    exchanged[a] = lists[a][:i] + lists[b][k:]
                    exchanged[b] = lists[b][:k] + lists[a][i:]
                    yield join(exchanged)


def solve_ga(instance: SchedulingInstance, settings: GaSettings = GaSettings(), seed: int = 0) -> Plan:
    rng = random.Random(seed)
    n_tasks, n_robots = instance.n_tasks, instance.n_robots
    cache: Dict[Chromosome, float] = {}

    def fitness(chrom: Chromosome) -> float:
        value = cache.get(chrom)
        if value is None:
            run = decode_task_lists(instance, split(*chrom))
            value = run.elapsed if run.complete else math.inf
            cache[chrom] = value
        return value

    def better(a: Chromosome, b: Chromosome) -> bool:
        return fitness(a) < fitness(b) - 1e-9

    def spent() -> bool:
        return len(cache) >= settings.max_evaluations

    def random_chromosome() -> Chromosome:
        order = list(range(n_tasks))
        rng.shuffle(order)
        cuts = tuple(sorted(rng.randint(0, n_tasks) for _ in range(n_robots - 1)))
        return tuple(order), cuts

    def tournament(population: List[Chromosome]) -> Chromosome:
        return min(rng.sample(population, min(settings.tournament, len(population))), key=fitness)

    population = [random_chromosome() for _ in range(settings.population)]
    best = min(population, key=fitness)
    stall = 0
    generation = 0
    for generation in range(1, settings.generations + 1):
        if spent():
            break
        ranked = sorted(population, key=fitness)
        children = ranked[:settings.elite]
        seen = set(children)
        while len(children) < settings.population:
            mother, father = tournament(population), tournament(population)
            if rng.random() < settings.crossover_rate:
                order = _order_crossover(rng, mother[0], father[0])
                cuts = tuple(sorted(m if rng.random() < 0.5 else f for m, f in zip(mother[1], father[1])))
            else:
                order, cuts = mother
            if rng.random() < settings.mutation_rate:
                order, cuts = _mutate(rng, order, cuts, n_tasks)
            tries = 0
            while (order, cuts) in seen and tries < 10:    # keep the population diverse
                order, cuts = _mutate(rng, order, cuts, n_tasks)
                tries += 1
            seen.add((order, cuts))
            children.append((order, cuts))
        population = children
        leader = min(population, key=fitness)
        if fitness(leader) < fitness(best) - 1e-9:
            best, stall = leader, 0
        else:
            stall += 1
            if stall >= settings.stall_generations:
                break
    # Memetic finish: hill-climb from the best chromosome, then kick the best with a few random
    # mutations and climb again, until `stall_generations` kicks in a row bring nothing better
    # (the evolution alone converges early on large teams).
    def climb(start: Chromosome) -> Chromosome:
        improved = True
        while improved and not spent():
            improved = False
            for candidate in _neighbours(start):
                if spent():
                    break
                if better(candidate, start):
                    start, improved = candidate, True
                    break
        return start

    best = climb(best)
    fruitless = 0
    while not spent() and fruitless < settings.stall_generations:
        kicked = best
        for _ in range(settings.kick_mutations):
            kicked = _mutate(rng, *kicked, n_tasks)
        climbed = climb(kicked)
        if better(climbed, best):
            best, fruitless = climbed, 0
        else:
            fruitless += 1
    run = decode_task_lists(instance, split(*best))
    return plan_from_run("ga", run, seed=seed, generations=generation, evaluations=len(cache),
                         fitness=fitness(best))
