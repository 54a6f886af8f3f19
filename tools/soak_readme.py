# Usage: python3 tools/soak_readme.py OUT  (OUT = a bench_soak output directory)
# Markdown figures for docs/reliability.md from one bench_soak output directory.
import csv, json, statistics, sys
out = sys.argv[1]
j = json.load(open(f'{out}/summary.json'))
rows = list(csv.DictReader(open(f'{out}/samples.csv')))
loads = [float(r['load1']) for r in rows]
m = j['memory']; w = j['watchdog']; st = j['stream']
faults = j['faults']
nice = j['parameters'].get('ipsd_nice')
prio = ('ipsd at normal priority' if nice in (None, 0) else
        f"ipsd at nice {nice} (bench_soak --nice, as the packaged unit's Nice=)")
print(f"Measured {j['measured_s']:.0f} s, {len(faults)} faults, load average (1 min) over the run "
      f"{min(loads):.1f}–{max(loads):.1f} (mean {statistics.mean(loads):.1f}) on this 2-core machine "
      f"(what else ran: see the run's notes); {prio}. Result: **{'PASSED' if j['passed'] else 'FAILED'}** (bench_soak's verdict).")
print()
print("| figure | value |\n|---|---|")
print(f"| crashes | {j['crashes']} (exit status after SIGTERM {j['exit_status']}) |")
print(f"| threads start / end | {j['threads']['start']} / {j['threads']['end']} |")
print(f"| fds start / end | {j['fds']['start']} / {j['fds']['end']} |")
flat = m.get('flat')
verdict = '' if flat is None else (': **flat** (≤ 10 MiB/h)' if flat else ': **NOT flat** (> 10 MiB/h)')
print(f"| resident memory after {m['warmup_s']:.0f} s warm-up / end | {m['rss_mib_after_warmup']:.1f} / {m['rss_mib_end']:.1f} MiB (range {m['rss_mib_min_after_warmup']:.1f}–{m['rss_mib_max_after_warmup']:.1f}; least-squares trend {m['slope_mib_per_hour']:+.1f} MiB/h){verdict} |")
print(f"| watchdog pings / missed | {w['pings']} / {w['missed']} (widest interval {w['widest_interval_s']:.2f} s, limit 10 s) |")
print(f"| datagrams / lost (sequence) / malformed | {st['datagrams']} / {st['datagrams_lost']} / {st['malformed']} |")
print(f"| widest silence of the whole stream | {st['widest_silence_s']:.2f} s |")
ex = sum(1 for g in j['gaps'] if g['excused']); un = [g for g in j['gaps'] if not g['excused']]
print(f"| camera silences > 1 s | {ex} excused (unplugged / restarting), {len(un)} not excused, {sum(1 for g in un if g['camera_driver_drops_around'] > 0)} of them with that camera's driver drops around them |")
print()
print("| minute | resident MiB | threads | fds | load (1 min) | ipsd CPU % | driver drops (all cameras, cumulative) |\n|---|---|---|---|---|---|---|")
for r in j['per_minute']:
    t = r['t_s'] / 60
    if round(t) % 5 == 0 or r is j['per_minute'][-1]:
        cpu = r['ipsd_cpu_pct']
        print(f"| {t:.0f} | {r['rss_mib']:.1f} | {r['threads']} | {r['fds']} | {r['load1']:.2f} | {'–' if cpu is None else round(cpu)} | {r['driver_drops']} |")
print()
print("| fault | count | recovery median / max | checks failed |\n|---|---|---|---|")
for kind in ['unplug', 'corrupt', 'hup-good', 'hup-bad', 'hup-cams', 'listener', 'garbage']:
    fs = [f for f in faults if f['kind'] == kind]
    if not fs: continue
    rec = sorted(f['recovery_s'] for f in fs if f['recovery_s'] is not None)
    never = sum(1 for f in fs if f['recovery_s'] is None)
    failed = sum(1 for f in fs if 'NO' in f['check'])
    print(f"| `{kind}` | {len(fs)} | {rec[len(rec)//2]:.2f} / {rec[-1]:.2f} s{f' ({never} never)' if never else ''} | {failed} |")
if un:
    print()
    print("Silences not excused by a fault (camera, start, length, load, that camera's driver drops in the 10-s samples around it, the fault under way):")
    print()
    for g in un:
        print(f"- camera {g['camera']} at {g['at_s']:.0f} s, {g['length_s']:.2f} s, load {g['load1']:.1f}, drops {g['camera_driver_drops_around']}, during/after `{g['during']}`")
