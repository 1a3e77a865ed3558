% The notes' double-gimbal m-function, as printed, for
% `lagrange-xval check --model models/gimbal.xml --equations examples/matlab/double_gimbal_state_space_model.m`.
% The print shows 11zz, 12xx, 12yy, 12zz, read as I1zz, I2xx, I2yy, I2zz; `dydt = zeros(4,1)` and
% dydt(1) = dpsidt are read where the print runs them together. The function has no input.
% coordinates: psi, theta
function dydt = double_gimbal_state_space_model(t,y)
psi = y(1);
theta = y(2);
dpsidt = y(3);
dthetadt = y(4);
I1zz = 1e-3;
I2xx = 10e-3;
I2yy = 9e-3;
I2zz = 5e-3;
kpsi = 0.01;
kpsi = 0.01;
ktheta = 0.01;
dydt = zeros(4,1);
dydt(1) = dpsidt;
dydt(2) = dthetadt;
dydt(2) = dthetadt;
dydt(3) = -2*(I2xx-I2yy)/(I1zz+I2zz*(cos(theta))^2 + ...
I2xx*(sin(theta))^2)*cos(theta)*sin(theta)*dpsidt*dthetadt - kpsi*dpsidt;
dydt(4) = (I2xx-I2zz)/I2yy*sin(theta)*cos(theta)*dpsidt^2 - ktheta*dthetadt;
