"""PHAC-2 benchmark, feature transforms for ESZSL/SAE (negative result, see experiments/benchmarks/README.md).

Signed log ``sign(x) log(1 + |x|)`` and a rank-Gauss ``QuantileTransformer`` (fitted on each split's
training trials) before ESZSL and SAE, alone and in the DAP + ESZSL + SAE ensemble ("mean3"; "mean5"
adds the untransformed ESZSL and SAE). Needs the stage-2 score cache of phac2_accuracy.py::

    nice -n 5 python phac2_feature_transforms.py /tmp/tzsl_accuracy
"""
import pickle
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
from phac2_accuracy import embedding_scores, zrows
from phac2_posteriors import study_splits
from sklearn.preprocessing import QuantileTransformer

from tzsl.features import dataset_features
from tzsl.studies.zero_shot.study import split_masks

warnings.simplefilter("ignore")
f = dataset_features('phac2-penn')
o = f.objects
X0 = f.X.reshape(len(o), -1)
res = []
for kind, _i, s in study_splits(f, 20, 0):
    base = pickle.loads((Path(sys.argv[1]) / f'scores_{s.name}.pkl').read_bytes())
    a = list(s.kept_attributes)
    tr, te = split_masks(f, s)
    rows = f.attributes.loc[np.unique(o[tr]), a].to_numpy(float)
    K = f.attributes.loc[list(s.test_objects), a].to_numpy(float)
    y = base['y']
    out = {'kind': kind}
    for tname in ('slog', 'quantile'):
        if tname == 'slog':
            Xt = np.sign(X0) * np.log1p(np.abs(X0))
            Xtr, Xte = Xt[tr], Xt[te]
        else:
            q = QuantileTransformer(output_distribution='normal', n_quantiles=200, random_state=0).fit(X0[tr])
            Xtr, Xte = q.transform(X0[tr]), q.transform(X0[te])
        S = {}
        for n in ('eszsl', 'sae'):
            S[n] = embedding_scores(n, Xtr, o[tr], rows, Xte, K)[0]
            out[f'{n}-{tname}'] = (S[n].argmax(1) == y).mean()
        out[f'mean3-{tname}'] = ((zrows(base['S']['dap-avg[paper]']) + zrows(S['eszsl'])
                                  + zrows(S['sae'])).argmax(1) == y).mean()
        out[f'mean5-{tname}'] = ((zrows(base['S']['dap-avg[paper]']) + zrows(S['eszsl']) + zrows(S['sae'])
                                  + zrows(base['S']['eszsl']) + zrows(base['S']['sae'])).argmax(1) == y).mean()
    out['mean3'] = ((zrows(base['S']['dap-avg[paper]']) + zrows(base['S']['eszsl'])
                     + zrows(base['S']['sae'])).argmax(1) == y).mean()
    print(s.name, {k: round(v, 2) for k, v in out.items() if k != 'kind'}, flush=True)
    res.append(out)
print(pd.DataFrame(res).groupby('kind').mean().T.round(3))
