import json, filecmp, os
import sys
OUT=sys.argv[1] if len(sys.argv) > 1 else '/tmp/ood2'
rows=[]
for m in ['bunny-noise-0.5','horse-noise-0.25','igea-noise-0.5','igea-noise-0.25','noisy2m']:
    core=json.load(open(f'{OUT}/{m}-core.json'))
    ct=open(f'{OUT}/{m}-core.time').read().split()
    inp=core['input']
    print(f"| {m} | in core | {inp.get('points_out', inp.get('points'))} | {core['particles']['count']} | {ct[0]} s | {int(ct[2])/1024:.0f} MB | denoise, noise, normals {sum(inp['preprocess_seconds'][k] for k in ('denoise','noise','normals')):.2f} s | – |")
    for b in ['64MiB','1GiB','256MiB','1GiB-again']:
        f=f'{OUT}/{m}-{b}.json'
        if not os.path.exists(f): continue
        j=json.load(open(f)); t=open(f'{OUT}/{m}-{b}.time').read().split()
        same=filecmp.cmp(f'{OUT}/{m}-core.ply', f'{OUT}/{m}-{b}.ply', shallow=False)
        tl=j['tiles']; pre=tl['preprocessing']
        print(f"| {m} | {b} ({tl['count']} tiles) | {tl['sampling']['relax_points']} relaxed | {j['particles']['count']} | {t[0]} s | {int(t[2])/1024:.0f} MB | checks {tl['seconds']['checks']:.2f} s | {'same bytes' if same else 'differ'}; moved {pre['denoised']['moved'] if pre['denoised'] else None} (core {core['input']['denoised']['moved']}) |")
